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
// Velocity estimator: least-squares slope of the last N = round(velocity_window_s * scan_rate_hz)
// angles, updated from running sums in O(1). For a constant velocity it is unbiased and its estimate
// refers to the window centre, i.e. it lags by delay_s() = (N - 1) / (2 fs) (0.2475 s for 0.5 s at
// 200 Hz). With white angle noise sigma [deg] its standard deviation is
// sigma * sqrt(12 / (N (N^2 - 1))) * fs [deg/s] (velocity_noise_rad_s()); 0.1 deg gives 0.0012 rad/s
// at the defaults, five times below the hold threshold.
//
// With the dynamic model active (Calibration::active), angle_deg is its online inverse instead
// (dynamic_model.hpp): no direction is decided, so the estimator above only reports velocity and
// phase (POF_ANGLE, the statistics) and sets the same quality flags.
//
// With effect terms in the calibration (Calibration::gap, gap_terms.hpp, docs/calibration.md
// "`[gap]`: effect terms and how the compensator applies them"), each scan also: notches the
// normalised voltage at every periodic_interference frequency, subtracts the sensor-side terms'
// voltage predicted at the previous scan's angle before the inverse (either model), and undoes the
// delay and the backlash on the angle the inverse gives. The sensor's velocity is then estimated
// from f5 of the voltage without the terms (a creep relaxing in a hold must not look like a
// movement); angle_uncomp_deg stays f5 of the voltage as measured.
//
// Threading: one instance per sensor stream, used from one thread. step() and reset() never
// allocate, never throw and never block; the constructor allocates the window.
#include <cstdint>
#include <limits>
#include <vector>

#include "pof/core/calibration.hpp"
#include "pof/core/dynamic_model.hpp"
#include "pof/core/gap_terms.hpp"
#include "pof/core/model.hpp"
#include "pof/core/normalise.hpp"
#include "pof/core/quality.hpp"

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
};

class OnlineCompensator {
 public:
  /// Throws std::invalid_argument on settings that cannot work (rate or window <= 0, hold >= move),
  /// a dynamic model marked active that is absent or invalid, or [gap] terms that cannot be
  /// applied at s.scan_rate_hz (the first of gap_problems(), described).
  OnlineCompensator(const Calibration& cal, const CompensatorSettings& s = {});

  /// One scan. angle_ref_deg is only used with VelocitySource::kReference (pass NaN otherwise).
  CompensatedScan step(double sensor_v, double reference_v, double angle_ref_deg = kNoReference) noexcept;

  /// Forget the velocity history (after lost scans); the next output carries quality::kGap and
  /// kSettling until the window has refilled.
  void reset() noexcept;

  [[nodiscard]] double delay_s() const noexcept;
  [[nodiscard]] double velocity_noise_rad_s(double angle_noise_deg) const noexcept;
  [[nodiscard]] int window() const noexcept { return n_; }
  [[nodiscard]] const Calibration& calibration() const noexcept { return cal_; }
  [[nodiscard]] const CompensatorSettings& settings() const noexcept { return s_; }

  static constexpr double kNoReference = std::numeric_limits<double>::quiet_NaN();

 private:
  void clear_window() noexcept;
  double push(double y) noexcept;  // returns slope [deg/scan], NaN with < 2 samples
  double push_slope() const noexcept;  // the window's slope [deg/scan] as it is, NaN with < 2 samples
  double short_slope() const noexcept;  // the reversal window's slope [deg/scan], NaN until it is full
  double recent_slope(int k) const noexcept;  // least-squares slope of the newest k scans [deg/scan]
  double& ring_back(int back) noexcept;  // the window's entry `back` scans before the newest
  void refresh_sums() noexcept;         // s0_, s1_ rebuilt from the ring
  // The f5-angle step [deg] the paper model predicts for a change of direction from `from` to `to`
  // at angle [deg] (both branches at the lowest calibrated speed; f5 in holds).
  double predicted_step(double angle, Direction from, Direction to) const noexcept;
  // Model steps (CompensatorSettings::model_steps): tracks the f5 angle's noise, and when the
  // newest block of the window stepped as predicted for a change of direction returns that
  // direction (else
  // phase_), the step taken out of the window.
  Direction model_step() noexcept;
  // The state of one chain of [gap] terms over one angle: the terms, the angle they were last
  // advanced to and the voltage inverted then.
  struct TermsChain {
    GapCorrector terms;
    double angle = std::numeric_limits<double>::quiet_NaN();  // the previous scan's angle [deg]
    double u = std::numeric_limits<double>::quiet_NaN();      // the voltage inverted then [V]
    void restart() noexcept {
      terms.reset();
      angle = u = std::numeric_limits<double>::quiet_NaN();
    }
  };
  // A chain's voltage at this scan's angle, with velocity w [rad/s] and direction d: solved from
  // its previous angle (f5 of v for the first) on the model linearised there (slope dA/dv
  // `slope`), the terms exact (see terms_voltage in compensator.cpp).
  double terms_voltage(const TermsChain& c, double v, double reference_v, double w, Direction d, double slope) const noexcept;
  // The published chain's voltage: slope of the active model.
  double terms_voltage(double v, double reference_v, double w, Direction d) const noexcept;
  // f5 of v with the quiet chain's terms (voltage *g) taken off: the velocity source's angle.
  double quiet_angle(double v, double reference_v, double* g) const noexcept;
  // Commits this scan's quiet angle and the voltage f5 inverted (v - g) to the quiet chain; on the
  // dynamic model with a play, the play's side follows that voltage's dynamic inverse (play_inverter_).
  void commit_quiet(double angle, double u, double reference_v) noexcept;
  // A scan the quiet chain does not commit: the windows that would span it restart.
  void skip_quiet() noexcept;
  // dA/dv [deg/V] of the active model at angle [deg] with velocity w and direction d.
  double model_slope(double angle, double w, Direction d) const noexcept;
  // The angle of normalised voltage v (the terms' voltage already subtracted) through the active
  // model, the [gap] kinematics undone when there are terms; w and d the paper chain's.
  double angle_of(double v, double reference_v, double w, Direction d, bool* clamped) noexcept;

  Calibration cal_;
  CompensatorSettings s_;
  bool dynamic_ = false;
  DynamicInverter inverter_;
  // The dynamic model with a [gap] play: the model's inverse of the quiet chain's voltage, the angle
  // the play's side is decided on. f5 (the quiet angle) lacks the structure's relaxation and stop
  // operators: in the hold after a movement it falls back as the fibre relaxes, and a play fed it
  // falls back with it; the published angle carries the direction-switched terms, late at every
  // start and stop (docs/calibration.md, "[gap]", step 6).
  DynamicInverter play_inverter_;
  bool play_inverse_ = false;
  ReferenceGuard guard_;
  int n_ = 1;
  std::vector<double> ring_;
  int head_ = 0, count_ = 0;
  double s0_ = 0, s1_ = 0;   // sum y_j, sum j*y_j over the window (j = 0 oldest)
  int m_ = 0;                // reversal window [scans], 0 = off (m_ <= n_: it reads the same ring)
  std::int64_t since_refresh_ = 0;
  Direction phase_ = Direction::kHold;
  // Model steps: block length [scans] (0 = off), the offset taken out of the angles the window is
  // fed since the last clear, the mean square of the step statistic and how many scans it has
  // seen, and the scans until the long window may again change a direction that a step decided
  // (until then it still holds angles from before the step).
  int step_m_ = 0;
  std::vector<double> step_scratch_;  // the newest 4 blocks, newest first (model_step())
  double step_offset_ = 0;
  double stat_var_ = 0;
  std::int64_t stat_count_ = 0;
  int step_hold_ = 0;
  bool gap_pending_ = false;
  bool terms_ = false;  // [gap] terms run
  // Two copies of the same terms. `terms_chain_` is advanced with the published fibre angle (the
  // active model's inverse). `quiet_chain_` is advanced with f5 of the voltage after its own terms:
  // the sensor's velocity, hence the direction, is estimated on that angle, which never depends on
  // the branch the paper chain picked; on the paper chain its terms also give the published angle's
  // voltage, whose own angle overshoots at every late direction decision (docs/calibration.md,
  // "[gap]", steps 2 and 4). `terms_chain_` notches the voltage and undoes the kinematics, with the
  // velocity extrapolation's slope and the play's side of the quiet chain's (step 6 there).
  // The acceleration term lives in the quiet chain alone and both take its voltage from there: the
  // published angle goes through the active model's inverse, whose bend-lag inverse (dynamic
  // model, theta_f + tau_b theta_f') differentiates it once more, so an acceleration estimated on
  // that angle and subtracted before it is a closed loop through a third derivative; a blind
  // recording's hold (tau_b 56 ms, 0.0053 V s^2/rad) rang to 300 deg RMSE. The quiet angle goes
  // through no inverse but f5 (GapCorrector::advance makes it open-loop in the term itself).
  TermsChain terms_chain_, quiet_chain_;
  bool quiet_committed_ = false;  // the quiet chain has this scan's angle (its kinematics are current)
  // The terms' slope dg/dA is a difference over this step [deg] (their bases are smooth or
  // piecewise linear in A: stop and play operators).
  static constexpr double kTermsSlopeStepDeg = 1e-3;
  // 1 + s g' below this (the terms cancelling most of the model's slope) is held here.
  static constexpr double kMinTermsDivisor = 0.25;
  // The solve for this scan's angle (terms_voltage): at most this many Newton steps to a bracket,
  // and as many regula falsi steps within it, down to kTermsTolDeg. Piecewise linear terms close
  // in a few; the bound keeps a scan's work fixed.
  static constexpr int kTermsSearchSteps = 12;
  static constexpr double kTermsTolDeg = 1e-6;
};

}  // namespace pof::core
