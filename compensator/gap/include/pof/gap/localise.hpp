#pragma once
// Localising a residual: by movement phase, angle, velocity, time, frequency and by
// cross-correlation with the inputs at lags (docs/gap.md, step 2).
#include <string>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "pof/gap/signals.hpp"

namespace pof::gap {

/// Movement phase of each scan.
enum class Phase : int { kHold = 0, kAfterStop, kReversal, kAccel, kConstantVelocity, kCount };
const char* phase_name(Phase p);

/// Phase labels: hold (>= 3 s after a movement), after_stop (< 3 s after a movement stops),
/// reversal (first 0.5 s of a movement opposite to the previous one), accel (|acc| > 0.1 rad/s^2),
/// constant_velocity (the rest of the movement).
std::vector<Phase> classify_phases(const Kinematics& k, double dt);

struct Localisation {
  nlohmann::json detail;   // tables: phase, angle bins, velocity bins, time, spectrum, xcorr
  std::string sentence;    // "concentrated in ..." with numbers
};

/// r: residual [deg]. The inputs for the cross-correlation come from s and k.
Localisation localise(const Eigen::VectorXd& r, const Signals& s, const Kinematics& k,
                      const std::vector<Phase>& phases);

/// RMS of r over each phase (NaN-free: phases without scans are omitted).
nlohmann::json phase_rms(const Eigen::VectorXd& r, const std::vector<Phase>& phases);

}  // namespace pof::gap
