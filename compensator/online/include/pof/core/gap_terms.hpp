#pragma once
// The effect terms `pof gap` finds (docs/gap.md) and the compensator applies (docs/calibration.md,
// "`[gap]`: effect terms and how the compensator applies them"). The model voltage is
//
//   v_model(k) = baseline(A_k, w_k, dir_k) + sum over terms, sum over i of coefficients_v[i] basis_i(k)
//
// with A the angle the fibre sees [deg], w the signed angular velocity [rad/s], dir the direction,
// and the baseline the calibration's active model (the paper's chain or the dynamic model). Two
// effects act on the kinematics instead: time_delay (the fibre sees the angle late) and backlash
// (play between the joint and the reference potentiometer); they are GapModel::delay_s and
// GapModel::backlash_deg, never terms. The effect catalogue is pof/core/effects.hpp.
//
// GapModel is what the calibration file holds ([gap]; pof/io/calibration_file.hpp reads and writes
// it); gap_problems() says which of its terms the compensator cannot apply and why; GapCorrector
// is the online part OnlineCompensator runs per scan (compensator.hpp):
//
//   filter(v_norm)            notch at every periodic_interference frequency
//   voltage_at(A, ...)        the terms' voltage if the fibre angle now is A (the compensator
//                             passes the previous scan's estimate), subtracted before the inverse
//   advance(A, reference_v, dA/dv)  commits the fibre angle A the inverse gave; returns the angle
//                             of the reference the calibration was made against (delay and backlash
//                             undone)
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "pof/core/dynamic_model.hpp"
#include "pof/core/effects.hpp"
#include "pof/core/model.hpp"

namespace pof::core {

struct Calibration;

/// Version of the [gap] section's layout (its own schema_version key).
inline constexpr int kGapSchemaVersion = 1;

/// One accepted effect: coefficients_v[i] multiplies basis function i of the effect (units: volts
/// per unit of the basis; the bases and theta's meaning per effect are in docs/calibration.md).
struct GapTerm {
  std::string effect;                    // an id of kEffectIds, as written (an unknown id is kept for gap_problems)
  double theta = 0;                      // the effect's nonlinear parameter (0 where it has none)
  std::vector<double> coefficients_v;    // one per basis function
  std::vector<double> thresholds_deg;    // memory_hysteresis (theta 0): the stop operators' thresholds r_i
  std::vector<double> relay_centres_deg;  // memory_hysteresis (theta = relay half-width > 0): the knots c_i
  std::vector<double> time_constants_s;  // viscoelastic_relaxation: the relaxation times tau_j
  std::vector<std::pair<std::string, double>> parameters;  // physical parameters for humans, in file order
  int line = 0;                          // where the term starts in its file (0: not read from a file)
};

struct GapModel {
  double delay_s = 0;       // time_delay: the sensor sees A(t - delay_s); 0 = none
  double backlash_deg = 0;  // backlash: belt play width b between the reference and the joint; 0 = none
  std::vector<GapTerm> terms;

  [[nodiscard]] bool empty() const { return delay_s == 0 && backlash_deg == 0 && terms.empty(); }
};

/// The number of basis functions (= coefficients) of a term of effect e, nullopt for an effect
/// that is never a term (time_delay, backlash). memory_hysteresis has one per threshold (or per
/// relay knot) and viscoelastic_relaxation one per time constant: pass their counts.
std::optional<std::size_t> basis_size(Effect e, std::size_t n_thresholds = 0, std::size_t n_time_constants = 0);

/// memory_hysteresis in its relay form (theta = h > 0): Preisach relays of half-width h, one every
/// kRelaySpacingDeg from the first knot of relay_centres_deg to the last, each weighted by the
/// knots' coefficients interpolated linearly at its centre (docs/calibration.md, "[gap]"). A relay
/// is up (+1) once the angle reaches centre + h, down (-1) once it falls to centre - h, and keeps
/// its state in between (Mayergoyz 1991, "Mathematical Models of Hysteresis", ch. 1): its loop sits
/// at an absolute angle, which stop operators, whose loops follow the reversals, cannot draw.
inline constexpr double kRelaySpacingDeg = 1.0;
inline constexpr std::size_t kMaxRelays = 361;  // a knot span of 360 deg
/// One relay of the bank: its centre, and its weight (1 - frac) c[knot] + frac c[knot + 1].
struct RelayPlace {
  double centre_deg = 0;
  std::size_t knot = 0;
  double frac = 0;
};
/// The relays of knots c_1 < ... < c_m (m >= 2, spanning at most kMaxRelays relays), in order of
/// centre; none for knots that are not.
std::vector<RelayPlace> relay_places(const std::vector<double>& knots);
/// Each relay runs core::relay_step (dynamic_model.hpp) from core::relay_start.

/// Why part of a GapModel cannot be applied online.
struct GapProblem {
  std::size_t term = 0;   // 1-based term number; 0: the section's own keys (delay_s, backlash_deg)
  std::string effect;     // the term's effect id, or the key ("delay_s") when term == 0
  std::string why;
  int line = 0;           // GapTerm::line
  /// "[gap] term 2 'drift': a trend over the calibration recording cannot be applied online; ..."
  [[nodiscard]] std::string describe() const;
};

/// Every term (and section key) the compensator cannot apply, and why: drift (a trend over the
/// calibration recording), an unknown effect, a kinematic effect given as a term, a coefficient
/// count that does not match the basis, non-finite numbers, thresholds or time constants not
/// positive, a nonlinear parameter out of range, and with scan_rate_hz > 0 a periodic_interference
/// frequency at or above the Nyquist frequency scan_rate_hz / 2. Empty: everything applies.
std::vector<GapProblem> gap_problems(const GapModel& g, double scan_rate_hz = 0);

/// Limits that keep the corrector's state small and fixed (the per-scan work bounded).
inline constexpr std::size_t kMaxGapTerms = 32;
inline constexpr double kMaxGapDelayS = 1.0;          // |delay_s|: a DAQ or filter delay, not a second
inline constexpr double kMaxGapBacklashDeg = 20.0;    // more play than this is a broken belt
inline constexpr double kMaxAccelerationWindowS = 1.0;  // acceleration_dependence: h [s]
/// acceleration_dependence online: the angle noise the term may add, as a multiple of the angle's
/// own white noise; the estimate's window is lengthened until it does (GapCorrector).
inline constexpr double kMaxAccelerationNoiseGain = 0.5;
/// acceleration_dependence online: the causal quadratic least-squares fit over the newest n
/// committed angles, a = 2 c / dt^2. Its weights: a = sum over i of weight[i] x A(k - i) [deg/s^2
/// per deg], i scans back from the newest angle.
std::vector<double> acceleration_weights(int n, double dt_s);
/// The acceleration estimate with those weights [deg/s^2]: sum over i of weights[i] x
/// angle_back(i), angle_back(i) the committed angle i scans back from the newest [deg]. The one
/// estimator: the compensator's online and `pof gap`'s column of it.
template <class AngleBack>
double acceleration_estimate(const std::vector<double>& weights, AngleBack&& angle_back) {
  double s = 0;
  for (std::size_t i = 0; i < weights.size(); ++i) s += weights[i] * angle_back(i);
  return s;
}
/// The n the corrector uses for a term of coefficient coefficient_v [V s^2/rad] and half-window
/// theta_s on a line of c9 [deg/V] at scan_rate_hz: 2 theta fs + 1 (at least 3), lengthened until
/// the term adds at most kMaxAccelerationNoiseGain x the angle's own white noise (at most
/// 2 kMaxAccelerationWindowS fs + 1).
int acceleration_window_scans(double coefficient_v, double theta_s, double c9, double scan_rate_hz);
/// The notch applied for periodic_interference (RBJ biquad, see GapCorrector): its quality factor.
inline constexpr double kNotchQ = 5.0;
/// The window of the quadratic fit that extrapolates a positive delay (GapCorrector) [s].
inline constexpr double kDelayFitWindowS = 0.12;
/// backlash and memory_hysteresis: the time constant of the first-order low-pass on the angle
/// that moves the memories, the play's side and the stop operators' (and relays') states [s]. A
/// play or stop operator fed the estimated angle is pushed to its noise's peaks in every hold (the
/// belt and the fibre see the joint, not the noise), so they move on the angle low-passed at about
/// the knee's own bandwidth (6 Hz); the play's offset is applied to the angle itself and the
/// operators are evaluated at it, which keeps the latency.
inline constexpr double kMemoryInputTauS = 0.025;
/// source_power_coupling: the reference level's averaging window [s].
inline constexpr double kSourceMeanWindowS = 1.0;

/// The online application of a GapModel at one scan rate. Construction allocates every buffer
/// (and throws std::invalid_argument naming the first of gap_problems()); after that no method
/// allocates or throws. Default-constructed it does nothing (no terms).
class GapCorrector {
 public:
  GapCorrector() = default;
  /// cal.gap (must be set), cal.model (the paper chain, for the bases that use it) and
  /// cal.reference_level_v at scan_rate_hz.
  GapCorrector(const Calibration& cal, double scan_rate_hz);

  /// The normalised sensor voltage with every periodic_interference frequency notched out.
  double filter(double v_norm) noexcept;

  /// The sum of the sensor-side terms [V] at this scan if the fibre angle now is angle_deg, given
  /// the angles committed by advance(). reference_v is this scan's reference voltage [V] (finite),
  /// velocity_rad_s and direction the compensator's estimate (velocity NaN counts as 0).
  [[nodiscard]] double voltage_at(double angle_deg, double reference_v, double velocity_rad_s,
                                  Direction direction) const noexcept;

  /// Commits this scan's fibre angle (and reference voltage) and returns the reference-equivalent
  /// angle: the delay inverse (velocity extrapolation by delay_s > 0, or the angle |delay_s| ago
  /// for delay_s < 0) followed by the play operator of half-width backlash_deg / 2.
  ///
  /// angle_per_volt [deg/V] is dA/dv of the model that gave angle_deg. The acceleration term's
  /// estimate must not feed on its own correction: an angle from which eps A'' was subtracted,
  /// differentiated twice and subtracted again is a causal inverse of (1 + eps d^2/dt^2), whose
  /// poles are undamped, and it diverges. So the angles that estimate it are open-loop ones,
  /// angle_deg + angle_per_volt x (this scan's acceleration voltage), the angle the voltage gives
  /// without that one term. 0: angle_deg already is such an angle (no acceleration term applied).
  ///
  /// play_angle_deg, if finite, is the angle whose movement decides the play's side instead of
  /// angle_deg (another model's estimate of the same joint angle; the delay inverse's offset at
  /// angle_deg is added to it); the play's offset is still applied to angle_deg's joint angle.
  /// extrapolate false: a positive delay's velocity extrapolation is left out this scan (the joint
  /// angle is angle_deg itself; the extrapolation's window still takes the angle).
  double advance(double angle_deg, double reference_v, double angle_per_volt,
                 double play_angle_deg = std::numeric_limits<double>::quiet_NaN(), bool extrapolate = true) noexcept;

  /// The angles of the last advance(): the one committed, the joint's (delay undone) and the
  /// reference-equivalent one (play applied; advance()'s return).
  struct Kinematics {
    double angle = 0, joint = 0, reference = 0;
  };
  [[nodiscard]] const Kinematics& last_kinematics() const noexcept { return kin_; }
  /// Whether the delay inverse is a velocity extrapolation (delay_s > 0).
  [[nodiscard]] bool extrapolates() const noexcept { return lead_.length() > 0; }

  /// The acceleration terms' voltage at this scan [V]: it depends on the committed angles only
  /// (included in voltage_at()).
  [[nodiscard]] double acceleration_voltage() const noexcept;
  [[nodiscard]] bool has_acceleration() const noexcept { return !accel_.empty(); }
  /// Whether voltage_at() depends on the velocity and direction (rate_dependent_hysteresis).
  [[nodiscard]] bool uses_velocity() const noexcept { return !rate_.empty(); }

  /// A scan without a usable input: the windows that would straddle it (acceleration, delay,
  /// notch) restart; the memories (creep, stop operators, play, reference mean) are kept, as the
  /// dynamic inverter keeps its own.
  void interrupt() noexcept;
  /// Lost scans: everything restarts from the next angle (relaxed creep, unloaded stop
  /// operators, relays demagnetised, play centred), as OnlineCompensator::reset() restarts its
  /// dynamic inverter.
  void reset() noexcept;

  [[nodiscard]] bool active() const noexcept { return active_; }
  /// The acceleration estimate's lag [s] (its window centre; 0 without acceleration_dependence).
  [[nodiscard]] double acceleration_lag_s() const noexcept;

 private:
  struct Creep {  // one relaxation: x_k = x_k-1 + alpha (A_k - x_k-1), basis x_k - A_k
    double alpha = 0, coefficient = 0, x = 0;
  };
  struct Stop {  // one Prandtl-Ishlinskii stop operator of threshold r
    double r = 0, coefficient = 0, s = 0;
  };
  struct Relay {  // one Preisach relay of the relay form (relay_places): up at alpha, down at beta
    double alpha = 0, beta = 0, centre = 0, coefficient = 0, r = 0;
  };
  struct RateHysteresis {
    double w0 = 1, c_shape = 0, c_paper = 0;
  };
  struct Acceleration {  // a = 2 c / dt^2 of a quadratic least-squares fit over the last n angles
    int n = 0;
    double coefficient = 0;
    std::vector<double> weights;  // acceleration_weights(n, dt), newest angle first [1/s^2]
  };
  struct Notch {  // RBJ biquad notch, direct form I
    double b0 = 1, b1 = 0, b2 = 1, a1 = 0, a2 = 0;
    double x1 = 0, x2 = 0, y1 = 0, y2 = 0;
    bool primed = false;
  };

  [[nodiscard]] double estimate_acceleration_voltage() const noexcept;  // from the committed angles

  bool active_ = false;
  ModelCoefficients paper_;
  double dt_ = 0.005, reference_level_v_ = 1;
  std::array<double, 4> static_{};  // coefficients of u^2 .. u^5
  // The angles the static polynomial is evaluated within: the calibration's range plus a tenth of
  // its span each side, held constant beyond (a quintic extrapolated runs away; see voltage_at).
  double static_lo_deg_ = -1e9, static_hi_deg_ = 1e9;
  std::vector<Creep> creep_;
  std::vector<Stop> stops_;
  std::vector<Relay> relays_;
  std::vector<RateHysteresis> rate_;
  std::vector<Acceleration> accel_;
  double accel_v_ = 0;  // the acceleration terms' voltage for the next scan (committed angles only)
  double c_source_vq_ = 0, c_source_r_ = 0;
  bool source_ = false;
  std::vector<Notch> notches_;

  // Committed fibre angles (newest at head_), as long as the longest acceleration window.
  std::vector<double> hist_;
  int hist_head_ = 0, hist_count_ = 0;
  // The reference voltage's causal mean over kSourceMeanWindowS.
  std::vector<double> ref_;
  int ref_head_ = 0, ref_count_ = 0;
  double ref_sum_ = 0;
  std::int64_t ref_since_refresh_ = 0;

  bool started_ = false;
  double stop_input_ = 0;  // the angle low-passed for the stop operators' states

  // Kinematics.
  LagInverse lead_;           // delay_s > 0: A + d A'
  std::vector<double> late_;  // delay_s < 0: the fibre angles of the last |d| fs + 2 scans
  int late_head_ = 0, late_count_ = 0;
  double late_scans_ = 0;     // |d| fs
  double half_play_ = 0;
  double play_ = 0;
  double play_input_ = 0;     // the angle low-passed for the play (kMemoryInputTauS)
  double memory_smooth_ = 0;  // the gain per scan of that low-pass and of stop_input_'s
  bool play_started_ = false;
  Kinematics kin_;
};

}  // namespace pof::core
