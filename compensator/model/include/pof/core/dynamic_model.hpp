#pragma once
// The dynamic sensor model: beyond Leal-Junior et al. 2017, whose section 4 names variable
// velocity, acceleration and the fibre's viscoelastic parameters as future work. Forward model
// from the angle history theta(t) [deg] to the normalised sensor voltage V [V] (docs/calibration.md,
// "The dynamic model"). Every term is a function of the fibre's own bend theta_f, which may lag
// the joint (the bend lag below); without it theta_f = theta:
//
//   V_k = q(x_k)                                   quasi-static polynomial, x = (theta_f - c) / s
//       + phi(w_k) * sum_i c_i S_i[theta]_k        rate-independent hysteresis with memory
//       + sum_j g_j m_j,k                          viscoelastic relaxation (Prony series)
//
//  * q is a polynomial of degree 1..kMaxDegree in the centred, scaled angle x (degree 1 is the
//    paper's f5 line, V = (c10 - theta) / c9).
//  * S_i are Prandtl-Ishlinskii stop operators of threshold r_i [deg] (Brokate & Sprekels 1996,
//    "Hysteresis and Phase Transitions", ch. 2; Kuhnen 2003, Eur. J. Control 9: 407-418):
//        S_i,k = clamp(S_i,k-1 + theta_k - theta_k-1, -r_i, r_i)
//    elastic until the element slips, i.e. a Maxwell-slip model. They carry the direction and
//    the memory: a hold keeps every S_i (no relaxation of the loop itself), a reversal half-way
//    unsaturates only the operators whose 2 r_i exceeds the stroke (minor loops, nested inside
//    the major loop, the return-point memory of the Preisach class). All c_i share one sign so
//    the branch between reversals is monotone and the inverse exists (Kuhnen 2003).
//  * phi is the rate dependence of that loop, a function of the causal speed estimate w [rad/s]
//    (two cascaded first-order filters of the angle's rate, speed_filter_s each):
//        phi = 1 + kappa w          kappa >= 0: the loop widens with speed (a lagging fibre);
//        phi = 1 / (1 - kappa w)    kappa <  0: it narrows with speed, as the paper's f1 measured
//    phi uses the speed of the previous scans only, so the model stays causal, and is held at its
//    value at the fastest identified speed beyond it (a loop is never extrapolated in speed).
//  * m_j is the generalised-Maxwell (Prony) state of time constant tau_j [s],
//        m_j' = theta' - m_j / tau_j     (exact for an angle ramping linearly within a scan)
//    a step of the angle gives g_j immediately, relaxing with tau_j (PMMA creep and relaxation:
//    Leal-Junior, Frizera, Pontes, Opt. Laser Technol. 93 (2017) 92-98); during a ramp at w it
//    offsets the branch by g_j tau_j w (1 - e^-t/tau_j): a second, linear rate dependence.
//  * the bend lag tau_b: the fibre, a viscoelastic polymer held in a sleeve on the leg, follows the
//    joint through a first-order (Kelvin-Voigt) lag, theta_f' = (theta - theta_f) / tau_b. Unlike a
//    Prony term, which adds a linear voltage, the lag moves the point at which the polynomial
//    and the operators are evaluated, so the loop widens with speed in proportion to the slope
//    and the reversal is rounded. Online the model is inverted to theta_f and then the lag is
//    undone, theta = theta_f + tau_b theta_f' (LagInverse).
//
// The model is linear in (q, c, g) once the thresholds r, time constants tau and kappa are fixed:
// that is how it is identified (dynamic_fit.hpp). Everything here is fixed-size: copying a model
// or running it never allocates.
#include <algorithm>
#include <array>
#include <cstdint>

namespace pof::core {

/// One step of a Prandtl-Ishlinskii stop operator of threshold r [deg] (the references above):
/// S_k = clamp(S_k-1 + (theta_k - theta_k-1), -r, r). The dynamic model's hysteresis and the
/// memory_hysteresis effect (gap_terms.hpp) both run it.
inline double stop_operator(double s, double increment_deg, double r_deg) {
  return std::clamp(s + increment_deg, -r_deg, r_deg);
}

/// One step of the play (backlash) operator of half-width r [deg], the stop operator's dual
/// (play = input - stop): y_k = clamp(y_k-1, x_k - r, x_k + r). The output stands still until the
/// input has crossed the play, then follows it r behind. The simulator's belt and the backlash
/// effect's inverse (gap_terms.hpp) run it.
inline double play_operator(double y, double x_deg, double r_deg) { return std::clamp(y, x_deg - r_deg, x_deg + r_deg); }

/// One step of a Preisach relay (Mayergoyz 1991, "Mathematical Models of Hysteresis", ch. 1) that
/// switches up at alpha and down at beta < alpha [deg]: +1 once the angle reaches alpha, -1 once
/// it falls to beta, else unchanged. The simulator's Preisach fibre and the memory_hysteresis
/// effect's relay form (gap_terms.hpp) both run it.
inline double relay_step(double state, double angle_deg, double alpha_deg, double beta_deg) {
  if (angle_deg >= alpha_deg) return 1.0;
  if (angle_deg <= beta_deg) return -1.0;
  return state;
}

/// A relay's state at the first angle: the demagnetised state, up where its centre (alpha + beta)
/// / 2 is below the angle (outside its loop this is the state the angle sets).
inline double relay_start(double angle_deg, double centre_deg) { return centre_deg < angle_deg ? 1.0 : -1.0; }

inline constexpr int kMaxDegree = 5;
inline constexpr int kMaxOperators = 16;
inline constexpr int kMaxPronyTerms = 8;
inline constexpr int kMaxLagWindow = 256;  // scans in the lag inverse's window (LagInverse)

struct DynamicModel {
  int degree = 1;
  double angle_centre_deg = 45, angle_scale_deg = 45;  // x = (theta - centre) / scale
  std::array<double, kMaxDegree + 1> poly{};           // q(x) = sum_k poly[k] x^k [V]
  int n_operators = 0;
  std::array<double, kMaxOperators> threshold_deg{};   // r_i > 0, ascending
  std::array<double, kMaxOperators> weight_v_per_deg{};  // c_i, one common sign
  double rate_gain_s_per_rad = 0;                      // kappa
  double speed_filter_s = 0.1;                         // each of the two speed filters
  double speed_limit_rad_s = 0.5;  // phi is held at its value here beyond it (no extrapolation of the loop)
  int n_prony = 0;
  std::array<double, kMaxPronyTerms> prony_tau_s{};
  std::array<double, kMaxPronyTerms> prony_gain_v_per_deg{};
  // The angle range the model was identified on; the inverse searches a margin around it.
  double angle_min_deg = 0, angle_max_deg = 90;
  double bend_lag_s = 0;       // tau_b [s], 0: the fibre bends with the joint
  double lag_window_s = 0.12;  // the lag inverse's fitting window (LagInverse) [s]

  /// q(theta) [V] and dq/dtheta [V/deg].
  [[nodiscard]] double quasi_static_v(double theta_deg) const;
  [[nodiscard]] double quasi_static_slope(double theta_deg) const;
  /// The rate factor phi at speed |w| [rad/s].
  [[nodiscard]] double rate_factor(double speed_rad_s) const;
  /// Half the height of the saturated major loop at rest [V]: sum c_i r_i.
  [[nodiscard]] double loop_half_height_v() const;
  /// A human-readable error if the parameters cannot be run (non-finite, thresholds not positive,
  /// mixed weight signs, too many terms), else an empty string.
  [[nodiscard]] const char* invalid_reason() const;
};

/// The model's memory at one scan: stop operators, Prony states, speed filters, last angle.
struct DynamicState {
  std::array<double, kMaxOperators> stop{};
  std::array<double, kMaxPronyTerms> prony{};
  double speed_f1 = 0, speed_f2 = 0;  // cascaded filters of the signed angle rate [deg/s]
  double angle_deg = 0;
  bool started = false;
};

/// Per-scan constants of a model at one scan rate (decays of the Prony terms and speed filters).
struct DynamicKernel {
  DynamicModel model;
  double dt_s = 0.005;
  std::array<double, kMaxPronyTerms> decay{}, ramp_gain{};  // e^{-dt/tau}, tau/dt (1 - e^{-dt/tau})
  double speed_alpha = 1;                                    // 1 - e^{-dt/speed_filter_s}

  DynamicKernel() = default;
  DynamicKernel(const DynamicModel& m, double scan_rate_hz);

  /// The model's voltage if the angle now is theta, given the state after the previous scan
  /// (state.started must be true). d_v_d_theta receives dV/dtheta there (may be null).
  [[nodiscard]] double voltage_at(const DynamicState& s, double theta_deg, double* d_v_d_theta) const;
  /// Commits theta as this scan's angle: updates every operator, Prony state and speed filter.
  void advance(DynamicState& s, double theta_deg) const;
  /// Forward model, one scan: advances the state to theta and returns V.
  double forward(DynamicState& s, double theta_deg) const;
  /// The causal speed estimate the rate factor uses now [rad/s] (magnitude).
  [[nodiscard]] double speed_rad_s(const DynamicState& s) const;
};

/// The fibre's bend behind the joint, theta_f' = (theta - theta_f) / tau_b, updated exactly for an
/// angle ramping linearly within a scan (as the Prony states). tau_b = 0 passes theta through.
class BendLag {
 public:
  BendLag() = default;
  BendLag(double tau_s, double scan_rate_hz);
  /// theta_f after this scan's joint angle theta [deg].
  double step(double theta_deg) noexcept;

 private:
  bool on_ = false, started_ = false;
  double decay_ = 0, gain_ = 0;  // e^{-dt/tau_b}, tau_b/dt (1 - e^{-dt/tau_b})
  double theta_ = 0, lag_ = 0;   // last joint angle, theta - theta_f
};

/// Undoes the bend lag online from the fibre angle alone: theta = theta_f + tau_b theta_f'. The
/// value and slope of theta_f at the newest scan come from a least-squares quadratic over the last
/// lag_window_s (a Savitzky-Golay filter evaluated at the window's end, Savitzky & Golay 1964,
/// Anal. Chem. 36: 1627-1639): exact while the bend's acceleration is constant, so gait-like
/// movements pass without the delay a low-pass filter would add; the price is noise, amplified by
/// noise_gain() (2.2 for a 0.08 s lag over 0.12 s at 200 Hz, against tau_b/dt = 16 for a plain
/// difference). One FIR of fixed length: O(window), no allocation. Until the window has filled
/// (start, after reset) theta_f is returned as it is.
class LagInverse {
 public:
  LagInverse() = default;
  LagInverse(double tau_s, double window_s, double scan_rate_hz);
  double step(double theta_f_deg) noexcept;
  void reset() noexcept { filled_ = 0; }
  [[nodiscard]] int length() const noexcept { return n_; }
  /// Standard deviation of the output for unit white noise on theta_f.
  [[nodiscard]] double noise_gain() const noexcept;

 private:
  bool on_ = false;
  int n_ = 0, filled_ = 0, head_ = 0;
  std::array<double, kMaxLagWindow> h_{};    // h_[i] weighs the scan i steps back
  std::array<double, kMaxLagWindow> buf_{};  // ring buffer of theta_f
};

/// Online inversion, one scan at a time, from the sensor alone: finds the angle whose forward
/// voltage, given the memory of the previous scans, equals the measured one. The branch is
/// monotone in theta between kinks (DynamicModel's sign rule), so a Newton step from the previous
/// angle, safeguarded by bisection inside a bracket of the model's range plus a margin, converges
/// in 2-4 evaluations of O(operators + Prony terms). No flexion/extension decision is taken: the
/// stop operators carry the direction, so there is nothing to decide late at a reversal.
/// Never allocates, never throws.
class DynamicInverter {
 public:
  DynamicInverter() = default;
  DynamicInverter(const DynamicModel& m, double scan_rate_hz);

  struct Result {
    double angle_deg = 0;        // the joint angle (theta_f with the bend lag undone)
    double fibre_angle_deg = 0;  // theta_f, what the voltage gives directly
    bool clamped = false;  // the measured voltage lies beyond the model's range: angle at the bound
    int iterations = 0;
  };
  /// The angle of this scan's normalised voltage v [V]; commits it to the memory. A non-finite v
  /// returns NaN, leaves the memory untouched and restarts the bend-lag inverse's window.
  Result step(double v) noexcept;
  /// The fibre angle theta_f whose voltage is v given the memory s, without committing it
  /// (fibre_angle_deg, clamped and iterations of the Result; angle_deg = theta_f).
  [[nodiscard]] Result solve(const DynamicState& s, double v) const noexcept;
  /// Forget the history (after lost scans): the next scan starts from a relaxed, centred state.
  void reset() noexcept {
    state_ = {};
    lag_.reset();
  }
  [[nodiscard]] const DynamicState& state() const noexcept { return state_; }
  [[nodiscard]] const DynamicKernel& kernel() const noexcept { return k_; }
  /// The search bracket [deg]: the identified range plus a margin of a quarter of its span.
  [[nodiscard]] double lower_deg() const noexcept { return lo_; }
  [[nodiscard]] double upper_deg() const noexcept { return hi_; }

 private:
  DynamicKernel k_;
  DynamicState state_;
  LagInverse lag_;
  double lo_ = -22.5, hi_ = 112.5;
  double sign_ = -1;  // sign of dV/dtheta (a POF loses light as it bends: negative)
};

}  // namespace pof::core
