#pragma once
// Online hysteresis compensation, one scan at a time (Leal-Junior et al. 2017, eqs. (11)/(12)):
//
//   normalise (reference guard) -> f5 angle (uncompensated) -> causal velocity estimate ->
//   direction with a dead band -> eq. (11) flexion / (12) extension, f5 alone in holds.
//
// The paper takes direction from the sign of the angle rate and w from its magnitude (section 2.2:
// "these velocities can be obtained from the rate of angle variation"); it assumes constant velocity
// per movement (its named future work is variable velocity and acceleration).
//
// OnlineCompensator owns the parts, each in a header of its own, and runs them in this order
// (docs/calibration.md, "Online compensation"):
//   ReferenceGuard      normalisation and its guard (normalise.hpp)
//   TermChains          the [gap] effect terms, if any: notch, quiet angle, terms voltage, the
//                       delay and play undone (term_chains.hpp)
//   VelocityWindow      the velocity: least-squares slope of the last N angles (velocity_window.hpp);
//                       it lags by delay_s() = (N - 1) / (2 fs), its noise is velocity_noise_rad_s()
//   StepDetector        model steps, paper model only (step_detector.hpp)
//   DirectionDetector   flexion, extension or hold with a dead band (direction_detector.hpp)
//   the angle           eq. (11)/(12) (f5 in holds), or on the dynamic model its AngleEstimator
//                       (angle_estimator.hpp) when the calibration carries its noises, else its
//                       per-scan DynamicInverter (dynamic_model.hpp). Neither decides a direction:
//                       the window and the detector then only report velocity and phase
//
// Threading: one instance per sensor stream, used from one thread. step() and reset() never
// allocate, never throw and never block; the constructor allocates every part.
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "pof/core/angle_estimator.hpp"
#include "pof/core/calibration.hpp"
#include "pof/core/direction_detector.hpp"
#include "pof/core/dynamic_model.hpp"
#include "pof/core/model.hpp"
#include "pof/core/normalise.hpp"
#include "pof/core/quality.hpp"
#include "pof/core/step_detector.hpp"
#include "pof/core/term_chains.hpp"
#include "pof/core/velocity_window.hpp"

namespace pof::core {

/// Where the velocity (and so the direction) comes from.
enum class VelocitySource : int {
  kSensor = 0,     // the sensor's own quasi-static angle f5(v): needs no potentiometer (default)
  kReference = 1,  // the reference angle passed to step() (potentiometer): the paper's setting
};

struct CompensatorSettings {
  double scan_rate_hz = 200.0;         // the paper's USB-6008 rate
  VelocitySource velocity_source = VelocitySource::kSensor;
  double velocity_window_s = 0.5;      // estimator window (delay (N-1)/2fs, noise above)
  double move_rad_s = 0.010;           // |w| above which a hold becomes movement (table 1 starts at 0.0209)
  double hold_rad_s = 0.006;           // |w| below which movement becomes a hold (dead band 0.006-0.010)
  // Reversal detector: a second, shorter least-squares window over the newest scans that may flip
  // flexion <-> extension before the long window does (its lag is (M-1)/2fs instead of 0.2475 s);
  // holds and starts are still decided by the long window. 0 = off (direction from the long window).
  double reversal_window_s = 0.0;
  double reversal_rad_s = 0.03;        // the short window's |w| in the opposite sense that flips
  // Model steps (paper model, sensor velocity source): eqs. (11)/(12) at w -> 0 do not meet f5, so
  // a sensor that follows them steps at every start, stop and reversal, against the motion; read as
  // motion, the step turned the direction the wrong way for ~0.1 s (a 2-3 deg error). A step of the
  // size and sign the calibration predicts for a change of direction, seen in the mean of the
  // newest step_block_s of f5 angles against the line through the 3 blocks before, switches the
  // direction at once and is taken out of the velocity window; a sensor without such steps never
  // matches and runs as with this off (docs/calibration.md, "Model steps").
  bool model_steps = true;
  double step_block_s = 0.025;         // block length M / fs, >= 3 scans (off unless the window holds 4)
  double step_tolerance = 0.4;         // |measured - predicted| <= this x |predicted|
  double step_min_snr = 6.0;           // |predicted| >= this x the step statistic's own spread
  // ... and >= this [deg]: a knee braking or turning at 3 rad/s^2 departs from the extrapolated
  // line by 0.2 deg, and a measured step needs only 60 % of its prediction (a smaller step changes
  // the angle little when missed).
  double step_min_deg = 0.4;
  // The dynamic model's angle: estimated (AngleEstimator) when the calibration has [estimator], or
  // inverted scan by scan. estimator_lag_s > 0 makes step() return the record of the scan that long
  // ago, its angle smoothed by the scans since (a fixed-lag smoother; docs/controller.md gives its
  // accuracy and delay; not with [gap] terms).
  bool estimate = true;
  double estimator_lag_s = 0;
  double velocity_tolerance = 0.10;    // relative margin on the calibrated velocity range before flagging
  double angle_margin_deg = 2.0;       // margin on the calibrated angle range before flagging
  double input_limit_v = 10.0;         // |input| at or above this is clipped (USB-6008 +-10 V range)
  double reference_min_ratio = 0.5;    // reference guard, see normalise.hpp
  double reference_max_ratio = 2.0;
  double reference_min_v = 0.05;
};

struct CompensatedScan {
  double angle_deg = 0;         // eq. (11)/(12); f5 in holds; NaN when the input is unusable
  double angle_uncomp_deg = 0;  // f5 alone
  double velocity_rad_s = 0;    // signed, positive in flexion; NaN until 2 samples are in the window
  Direction phase = Direction::kHold;
  std::int32_t quality = 0;     // quality::* bits (= angle_t.QUALITY_*)
  double angle_sigma_deg = std::numeric_limits<double>::quiet_NaN();  // the estimator's; NaN without one
};

class OnlineCompensator {
 public:
  /// Throws std::invalid_argument on settings that cannot work (rate or window <= 0, hold >= move),
  /// a dynamic model marked active that is absent or invalid, or [gap] terms that cannot be
  /// applied at s.scan_rate_hz (the first of gap_problems(), described).
  OnlineCompensator(const Calibration& cal, const CompensatorSettings& s = {});

  /// One scan. angle_ref_deg is only used with VelocitySource::kReference (pass NaN otherwise).
  CompensatedScan step(double sensor_v, double reference_v, double angle_ref_deg = kNoReference) noexcept;

  /// Forget the velocity history (after lost scans); the next output carries quality::kScansLost
  /// and kSettling until the window has refilled.
  void reset() noexcept;

  [[nodiscard]] double delay_s() const noexcept;
  [[nodiscard]] double velocity_noise_rad_s(double angle_noise_deg) const noexcept;
  [[nodiscard]] int window() const noexcept { return window_.size(); }
  [[nodiscard]] const Calibration& calibration() const noexcept { return cal_; }
  [[nodiscard]] const CompensatorSettings& settings() const noexcept { return s_; }
  /// True when the dynamic model's angle is estimated (AngleEstimator), not inverted.
  [[nodiscard]] bool estimating() const noexcept { return estimating_; }
  /// Scans between an input and the output that describes it: the estimator's fixed lag, else 0.
  [[nodiscard]] int lag_scans() const noexcept { return lag_; }
  /// The estimator's restarts after a divergence (0 when not estimating).
  [[nodiscard]] long estimator_divergences() const noexcept { return estimator_.divergences(); }

  static constexpr double kNoReference = std::numeric_limits<double>::quiet_NaN();

 private:
  // The window, the steps taken out of it and the direction restart (an unusable scan, lost scans).
  void clear_window() noexcept;
  // The active model's inverse of normalised voltage v (the terms' voltage already subtracted):
  // eq. (11)/(12) at |w| (f5 in holds) or the dynamic inverse; the [gap] kinematics undone.
  double angle_of(double v, double reference_v, double w, Direction d, CompensatedScan& out) noexcept;

  Calibration cal_;
  CompensatorSettings s_;
  bool dynamic_ = false;
  DynamicInverter inverter_;
  bool estimating_ = false;
  AngleEstimator estimator_;
  AngleEstimator::Result estimate_;  // its last output
  // A fixed lag of lag_ scans: the records of the last lag_ + 1 scans, published lag_ late.
  int lag_ = 0, head_ = 0, stored_ = 0;
  std::array<CompensatedScan, kMaxSmootherLag + 1> ring_{};
  CompensatedScan step_now(double sensor_v, double reference_v, double angle_ref_deg) noexcept;
  CompensatedScan delayed(const CompensatedScan& now) noexcept;
  // QUALITY_ANGLE_EXTRAPOLATED for a published angle outside the calibrated range plus the margin.
  void flag_angle_range(CompensatedScan& out) const noexcept;
  ReferenceGuard guard_;
  VelocityWindow window_;
  StepDetector steps_;
  DirectionDetector direction_;
  TermChains terms_;
  bool scans_lost_ = false;  // reset() was called: the next output carries quality::kScansLost
};

}  // namespace pof::core
