#pragma once
// What `pof gap` derives from a recording once: the reference-normalised voltage, the kinematics
// of the reference angle (velocity, acceleration, direction) and the baseline simulator's
// per-sample factors. Pure arithmetic on Eigen vectors (no files).
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "pof/core/model.hpp"
#include "pof/core/paper_refit.hpp"
#include "pof/io/recording.hpp"

namespace pof::gap {

/// |w| below this is a hold: while the knee holds, the quasi-static line f5 alone applies.
inline constexpr double kHoldSpeedRadS = 0.01;

/// The recording, normalised. v = sensor_v * reference_level_v / reference_v (brief, contracts),
/// with reference_level_v the median reference of the recording (no calibration file is needed).
struct Signals {
  Eigen::Index n = 0;
  double dt = 0;              // scan period [s] (constant rate required)
  double reference_level_v = 0;
  Eigen::VectorXd t;          // [s] from the first scan
  Eigen::VectorXd v;          // normalised sensor voltage [V]
  Eigen::VectorXd angle;      // reference angle [deg], smoothed over +-25 ms (signals.cpp says why)
  Eigen::VectorXd ref_rel;    // reference_v / reference_level_v - 1, 1 s centred mean (source power)
};

/// Builds Signals; throws pof::DataError on empty/short data, non-constant rate or a
/// non-positive reference (naming the source and the row).
Signals make_signals(const io::Recording& rec);

/// Kinematics of an angle trace: what the baseline simulator and the effects' columns read at
/// each scan. The simulator's voltage and its gradient are the search's (search.cpp,
/// build_design): on the dynamic baseline they come from the model's own regressors, so a paper
/// gradient computed here would be thrown away for every candidate's design.
struct Kinematics {
  Eigen::VectorXd angle;   // [deg] (the reference, possibly shifted by a candidate time delay)
  Eigen::VectorXd w;       // signed angular velocity [rad/s] (+ = flexion, angle increasing)
  Eigen::VectorXd acc;     // angular acceleration [rad/s^2]
  Eigen::VectorXd s_move;  // +1 flexion, -1 extension, 0 hold
  Eigen::VectorXd s_last;  // direction of the most recent movement, kept through holds (0 before any)
  std::vector<core::Direction> dir;
  std::vector<bool> quiet_hold;  // the +-125 ms velocity says "hold" (gates the short one)
};

/// Kinematics of `angle` (sampled every dt) delayed by delay_s: the angle seen at scan i is the
/// reference at t_i - delay_s (linear interpolation, clamped at the ends). Velocity is the slope of
/// a local linear fit over +-50 ms, gated by a +-125 ms fit (robust to potentiometer noise).
Kinematics make_kinematics(const Eigen::VectorXd& angle, double dt, double delay_s);

/// The joint angle behind a reference seen through belt backlash of width_deg (see signals.cpp):
/// shifts the angle by +-width/2 after each movement and restores the joint's motion while the
/// reference stands in the dead band before a reversal; then the joint's velocity and directions.
void apply_backlash(Kinematics& k, double width_deg, double dt);

/// The paper structure's voltage at every scan of k (eqs. 11/12 moving, f5 holding) at the
/// coefficients m, and its gradient in the refitted coefficients (pof/core/paper_refit.hpp) written to
/// `gradient` (n x core::kRefitParameters), so a fit can move every coefficient to first order
/// (docs/gap.md, section 1).
Eigen::VectorXd paper_voltage(const Kinematics& k, const core::ModelCoefficients& m,
                              Eigen::Ref<Eigen::MatrixXd> gradient);

/// Mean of x over the centred window of 2*half+1 samples, shortened at the ends to what exists.
Eigen::VectorXd moving_mean(const Eigen::VectorXd& x, Eigen::Index half);

/// Slope of a local linear fit of x over 2*half+1 samples, divided by dt: centred where the window
/// fits, and within half of either end the first (last) full window's slope.
Eigen::VectorXd local_slope(const Eigen::VectorXd& x, double dt, Eigen::Index half);

}  // namespace pof::gap
