#include "pof/core/gap_terms.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "pof/base/format.hpp"
#include "pof/core/calibration.hpp"
#include "pof/core/units.hpp"

namespace pof::core {

namespace {

constexpr double kPi = std::numbers::pi;
// The reference mean's running sum is rebuilt this often against rounding drift (as the
// compensator's velocity sums are).
constexpr std::int64_t kRefreshScans = 4096;

std::string num(double x) { return format_significant(x, 6); }

bool all_finite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

std::string effect_list() {
  std::string s;
  for (const std::string_view id : kEffectIds) s += (s.empty() ? "'" : ", '") + std::string(id) + "'";
  return s;
}

// A term's list of parameters that are each a threshold or a time (`key`, `needs` naming it in the
// message for an empty one): at least one, at most `most`, each finite and > 0; "" when it is.
std::string positive_list_problem(const std::vector<double>& v, const std::string& key, const std::string& needs, int most) {
  if (v.empty()) return "needs its " + needs + " (at least one)";
  if (v.size() > static_cast<std::size_t>(most))
    return "at most " + std::to_string(most) + " " + key + ", got " + std::to_string(v.size());
  for (const double x : v)
    if (!(x > 0) || !std::isfinite(x)) return key + " must be finite and > 0, got " + num(x);
  return {};
}

// A memory_hysteresis term in its relay form (theta > 0): its knots and the relays they make.
std::string relay_problem(const GapTerm& t) {
  const std::vector<double>& c = t.relay_centres_deg;
  if (!t.thresholds_deg.empty()) return "theta > 0 is the relay form: relay_centres_deg, not thresholds_deg";
  if (c.size() < 2 || c.size() > static_cast<std::size_t>(kMaxOperators))
    return "the relay form (theta > 0) needs 2 to " + std::to_string(kMaxOperators) + " relay_centres_deg, got " +
           std::to_string(c.size());
  if (!all_finite(c)) return "relay_centres_deg must be finite numbers";
  for (std::size_t i = 1; i < c.size(); ++i)
    if (!(c[i] > c[i - 1])) return "relay_centres_deg must be ascending, got " + num(c[i - 1]) + " then " + num(c[i]);
  if ((c.back() - c.front()) / kRelaySpacingDeg + 1 > static_cast<double>(kMaxRelays))
    return "relay_centres_deg may span at most " + num(kRelaySpacingDeg * static_cast<double>(kMaxRelays - 1)) + " deg";
  return {};
}

// The first reason the compensator cannot apply term t, or "" (the rate-independent checks, then
// the Nyquist check when scan_rate_hz > 0).
std::string term_problem(const GapTerm& t, double scan_rate_hz) {
  const std::optional<Effect> e = effect_of(t.effect);
  if (!e) return "not an effect of the catalogue (docs/gap.md): expected one of " + effect_list();
  switch (*e) {
    case Effect::kDrift:
      return "a trend over the calibration recording cannot be applied online; remove it or recalibrate";
    case Effect::kTimeDelay:
      return "a kinematic effect, given as [gap] delay_s, not as a term";
    case Effect::kBacklash:
      return "a kinematic effect, given as [gap] backlash_deg, not as a term";
    default:
      break;
  }
  if (!std::isfinite(t.theta)) return "theta must be a finite number";
  if (!all_finite(t.coefficients_v)) return "coefficients_v must be finite numbers";
  for (const auto& [name, value] : t.parameters)
    if (!std::isfinite(value)) return "parameters." + name + " must be a finite number";
  if (!t.thresholds_deg.empty() && *e != Effect::kMemoryHysteresis)
    return "thresholds_deg belongs to memory_hysteresis only";
  if (!t.relay_centres_deg.empty() && *e != Effect::kMemoryHysteresis)
    return "relay_centres_deg belongs to memory_hysteresis only";
  if (!t.time_constants_s.empty() && *e != Effect::kViscoelasticRelaxation)
    return "time_constants_s belongs to viscoelastic_relaxation only";
  if (*e == Effect::kMemoryHysteresis) {
    if (t.theta < 0) return "theta (0 for stop operators, else the relays' half-width [deg]) must be >= 0, got " + num(t.theta);
    if (t.theta > 0) {
      if (std::string why = relay_problem(t); !why.empty()) return why;
    } else if (!t.relay_centres_deg.empty()) {
      return "relay_centres_deg needs theta = the relays' half-width [deg] > 0 (theta 0 is the stop-operator form, "
             "with thresholds_deg)";
    } else if (std::string why = positive_list_problem(t.thresholds_deg, "thresholds_deg", "stop operators' thresholds_deg", kMaxOperators);
               !why.empty()) {
      return why;
    }
  }
  if (*e == Effect::kViscoelasticRelaxation)
    if (std::string why = positive_list_problem(t.time_constants_s, "time_constants_s", "time_constants_s", kMaxPronyTerms);
        !why.empty())
      return why;
  const std::size_t n_memory = t.theta > 0 ? t.relay_centres_deg.size() : t.thresholds_deg.size();
  const std::size_t want = *basis_size(*e, n_memory, t.time_constants_s.size());
  if (t.coefficients_v.size() != want)
    return "expected " + std::to_string(want) + " coefficients_v (one per basis function), got " +
           std::to_string(t.coefficients_v.size());
  switch (*e) {
    case Effect::kCreep:
      if (!(t.theta > 0)) return "theta (the creep time constant tau [s]) must be > 0, got " + num(t.theta);
      break;
    case Effect::kRateDependentHysteresis:
      if (!(t.theta > 0)) return "theta (the velocity scale w0 [rad/s]) must be > 0, got " + num(t.theta);
      break;
    case Effect::kAccelerationDependence:
      if (!(t.theta > 0) || t.theta > kMaxAccelerationWindowS)
        return "theta (the acceleration window h [s]) must be in (0, " + num(kMaxAccelerationWindowS) + "], got " + num(t.theta);
      break;
    case Effect::kPeriodicInterference:
      if (!(t.theta > 0)) return "theta (the frequency f [Hz]) must be > 0, got " + num(t.theta);
      if (scan_rate_hz > 0 && !(t.theta < 0.5 * scan_rate_hz))
        return "the frequency " + num(t.theta) + " Hz is at or above the Nyquist frequency " + num(0.5 * scan_rate_hz) +
               " Hz of " + num(scan_rate_hz) + " Hz scans: no notch can remove it";
      break;
    default:
      break;
  }
  return "";
}

}  // namespace

std::vector<RelayPlace> relay_places(const std::vector<double>& knots) {
  std::vector<RelayPlace> out;
  // At least two knots, spanning at most kMaxRelays relays (false for a NaN: no endless loop).
  if (knots.size() < 2 || !(knots.back() - knots.front() <= kRelaySpacingDeg * static_cast<double>(kMaxRelays - 1)))
    return out;
  std::size_t k = 0;
  // Centres by index, not by accumulating the spacing: every reader places them identically.
  for (std::size_t j = 0;; ++j) {
    const double c = knots.front() + kRelaySpacingDeg * static_cast<double>(j);
    if (c > knots.back() + 1e-9) break;
    while (k + 2 < knots.size() && c > knots[k + 1]) ++k;
    out.push_back({c, k, std::clamp((c - knots[k]) / (knots[k + 1] - knots[k]), 0.0, 1.0)});
  }
  return out;
}

std::optional<std::size_t> basis_size(Effect e, std::size_t n_thresholds, std::size_t n_time_constants) {
  switch (e) {
    case Effect::kStaticNonlinearity: return 4;
    case Effect::kDrift: return 1;
    case Effect::kCreep: return 1;
    case Effect::kRateDependentHysteresis: return 2;
    case Effect::kAccelerationDependence: return 1;
    case Effect::kSourcePowerCoupling: return 2;
    case Effect::kPeriodicInterference: return 4;
    case Effect::kMemoryHysteresis: return n_thresholds;
    case Effect::kViscoelasticRelaxation: return n_time_constants;
    case Effect::kTimeDelay:
    case Effect::kBacklash: return std::nullopt;
  }
  return std::nullopt;
}

std::string GapProblem::describe() const {
  if (term == 0) return "[gap] " + effect + ": " + why;
  return "[gap] term " + std::to_string(term) + " '" + effect + "': " + why;
}

std::vector<GapProblem> gap_problems(const GapModel& g, double scan_rate_hz) {
  std::vector<GapProblem> out;
  if (!std::isfinite(g.delay_s) || std::abs(g.delay_s) > kMaxGapDelayS)
    out.push_back({0, "delay_s", "expected a finite delay within +-" + num(kMaxGapDelayS) + " s, got " + num(g.delay_s), 0});
  if (!std::isfinite(g.backlash_deg) || g.backlash_deg < 0 || g.backlash_deg > kMaxGapBacklashDeg)
    out.push_back({0, "backlash_deg", "expected a play width in [0, " + num(kMaxGapBacklashDeg) + "] deg, got " + num(g.backlash_deg), 0});
  if (g.terms.size() > kMaxGapTerms)
    out.push_back({0, "terms", "at most " + std::to_string(kMaxGapTerms) + " terms, got " + std::to_string(g.terms.size()), 0});
  for (std::size_t i = 0; i < g.terms.size(); ++i)
    if (std::string why = term_problem(g.terms[i], scan_rate_hz); !why.empty())
      out.push_back({i + 1, g.terms[i].effect, std::move(why), g.terms[i].line});
  return out;
}

// --- GapCorrector ---------------------------------------------------------------------------------

namespace {
// 1 / sum over the n centred j of (j^2 - m2)^2, m2 the mean of j^2: the quadratic fit's norm.
double acceleration_norm(int n) {
  const double m2 = (static_cast<double>(n) * n - 1) / 12.0;
  double s = 0;
  for (int i = 0; i < n; ++i) {
    const double j = i - (n - 1) / 2.0;
    s += (j * j - m2) * (j * j - m2);
  }
  return 1.0 / s;
}
}  // namespace

std::vector<double> acceleration_weights(int n, double dt_s) {
  const double m2 = (static_cast<double>(n) * n - 1) / 12.0, norm = acceleration_norm(n);
  std::vector<double> w(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double j = (n - 1) / 2.0 - i;  // i scans back from the newest
    w[static_cast<std::size_t>(i)] = 2.0 * (j * j - m2) * norm / (dt_s * dt_s);
  }
  return w;
}

int acceleration_window_scans(double coefficient_v, double theta_s, double c9, double scan_rate_hz) {
  // `pof gap` estimates the acceleration from the smoothed reference angle; online it comes from
  // the sensor's angle, whose white noise sigma the fit turns into an acceleration noise of
  // sigma 2 sqrt(norm) / dt^2. Times the term's gain [deg per rad/s^2] that is the angle noise the
  // term adds: on a 0.95 deg/(rad/s^2) term over 0.05 s it is 58 sigma (docs/calibration.md,
  // "[gap]", Approximations, Acceleration). So the window is lengthened (up to
  // kMaxAccelerationWindowS) until the term adds at most kMaxAccelerationNoiseGain x the angle's
  // own noise; its lag grows with it.
  const double dt = 1.0 / scan_rate_hz;
  const double gain_deg = std::abs(coefficient_v * c9) * kRadPerDeg;  // deg of angle per deg/s^2
  const int n_max = static_cast<int>(std::lround(2 * kMaxAccelerationWindowS * scan_rate_hz)) + 1;
  int n = std::max(3, static_cast<int>(std::lround(2 * theta_s * scan_rate_hz)) + 1);
  while (n < n_max && gain_deg * 2.0 * std::sqrt(acceleration_norm(n)) / (dt * dt) > kMaxAccelerationNoiseGain) ++n;
  return n;
}

GapCorrector::GapCorrector(const Calibration& cal, double scan_rate_hz) {
  if (!cal.gap) throw std::invalid_argument("gap corrector: the calibration has no [gap] section");
  if (!(scan_rate_hz > 0) || !std::isfinite(scan_rate_hz)) throw std::invalid_argument("gap corrector: scan rate must be > 0");
  const GapModel& g = *cal.gap;
  if (const auto problems = gap_problems(g, scan_rate_hz); !problems.empty())
    throw std::invalid_argument(problems.front().describe());
  active_ = true;
  paper_ = cal.model;
  reference_level_v_ = cal.reference_level_v;
  if (std::isfinite(cal.angle_min_deg) && std::isfinite(cal.angle_max_deg) && cal.angle_max_deg > cal.angle_min_deg) {
    const double margin = 0.1 * (cal.angle_max_deg - cal.angle_min_deg);
    static_lo_deg_ = cal.angle_min_deg - margin;
    static_hi_deg_ = cal.angle_max_deg + margin;
  }
  dt_ = 1.0 / scan_rate_hz;
  int longest = 0;
  auto add_creep = [&](double tau, double c) { creep_.push_back({1.0 - std::exp(-dt_ / tau), c, 0.0}); };
  for (const GapTerm& t : g.terms) {
    const std::vector<double>& c = t.coefficients_v;
    switch (*effect_of(t.effect)) {
      case Effect::kStaticNonlinearity:
        for (std::size_t i = 0; i < 4; ++i) static_[i] += c[i];
        break;
      case Effect::kCreep:
        add_creep(t.theta, c[0]);
        break;
      case Effect::kViscoelasticRelaxation:
        for (std::size_t j = 0; j < t.time_constants_s.size(); ++j) add_creep(t.time_constants_s[j], c[j]);
        break;
      case Effect::kMemoryHysteresis:
        for (std::size_t i = 0; i < t.thresholds_deg.size(); ++i) stops_.push_back({t.thresholds_deg[i], c[i], 0.0});
        if (t.theta > 0)
          for (const RelayPlace& p : relay_places(t.relay_centres_deg))
            relays_.push_back({p.centre_deg + t.theta, p.centre_deg - t.theta, p.centre_deg,
                               (1 - p.frac) * c[p.knot] + p.frac * c[p.knot + 1], 0.0});
        break;
      case Effect::kRateDependentHysteresis:
        rate_.push_back({t.theta, c[0], c[1]});
        break;
      case Effect::kAccelerationDependence: {
        // The causal quadratic least-squares fit over the last 2h: n = 2h fs + 1 scans (at least
        // 3), lengthened until its noise is bounded (acceleration_window_scans); its lag grows
        // with it (acceleration_lag_s()).
        Acceleration a;
        a.coefficient = c[0];
        a.n = acceleration_window_scans(c[0], t.theta, paper_.c9, scan_rate_hz);
        a.weights = acceleration_weights(a.n, dt_);
        longest = std::max(longest, a.n);
        accel_.push_back(a);
        break;
      }
      case Effect::kSourcePowerCoupling:
        source_ = true;
        c_source_vq_ += c[0];
        c_source_r_ += c[1];
        break;
      case Effect::kPeriodicInterference: {
        // Robert Bristow-Johnson, "Cookbook formulae for audio EQ biquad filter coefficients"
        // (the W3C Audio EQ Cookbook), notch: H(z) = (1 - 2 cos w0 z^-1 + z^-2) / (a0 + a1 z^-1 + a2 z^-2).
        const double w0 = 2 * kPi * t.theta / scan_rate_hz;
        const double alpha = std::sin(w0) / (2 * kNotchQ);
        const double a0 = 1 + alpha;
        Notch n;
        n.b0 = 1 / a0;
        n.b1 = -2 * std::cos(w0) / a0;
        n.b2 = 1 / a0;
        n.a1 = -2 * std::cos(w0) / a0;
        n.a2 = (1 - alpha) / a0;
        notches_.push_back(n);
        break;
      }
      case Effect::kDrift:
      case Effect::kTimeDelay:
      case Effect::kBacklash:
        break;  // refused by gap_problems() above
    }
  }
  hist_.assign(static_cast<std::size_t>(std::max(longest, 1)), 0.0);
  if (source_) ref_.assign(static_cast<std::size_t>(std::max(1L, std::lround(kSourceMeanWindowS * scan_rate_hz))), 0.0);
  if (g.delay_s > 0) lead_ = LagInverse(g.delay_s, kDelayFitWindowS, scan_rate_hz);
  if (g.delay_s < 0) {
    late_scans_ = -g.delay_s * scan_rate_hz;
    late_.assign(static_cast<std::size_t>(std::floor(late_scans_)) + 2, 0.0);
  }
  half_play_ = 0.5 * g.backlash_deg;
  memory_smooth_ = 1.0 - std::exp(-1.0 / (kMemoryInputTauS * scan_rate_hz));
}

double GapCorrector::acceleration_lag_s() const noexcept {
  int n = 0;
  for (const Acceleration& a : accel_) n = std::max(n, a.n);
  return n == 0 ? 0.0 : ((n - 1) / 2.0 + 1.0) * dt_;
}

double GapCorrector::filter(double v) noexcept {
  for (Notch& n : notches_) {
    if (!n.primed) {  // start in the steady state of a constant input: no start-up transient
      n.x1 = n.x2 = n.y1 = n.y2 = v;
      n.primed = true;
    }
    const double y = n.b0 * v + n.b1 * n.x1 + n.b2 * n.x2 - n.a1 * n.y1 - n.a2 * n.y2;
    n.x2 = n.x1;
    n.x1 = v;
    n.y2 = n.y1;
    n.y1 = y;
    v = y;
  }
  return v;
}

double GapCorrector::voltage_at(double angle, double reference_v, double velocity_rad_s, Direction d) const noexcept {
  if (!active_) return 0.0;
  double v = 0;
  // The polynomial is fitted over the recording's angles only: beyond them it is held at its edge
  // value. Extrapolated, the quintic's u^5 grows fast enough to turn an angle error after a
  // reversal (a memory term whose elastic slope nearly cancels the model's) into a voltage that
  // pushes the angle further, and the angle runs away (docs/calibration.md, "[gap]", Approximations).
  const double u = static_nonlinearity_u(std::clamp(angle, static_lo_deg_, static_hi_deg_));
  const double u2 = u * u;
  v += u2 * (static_[0] + u * (static_[1] + u * (static_[2] + u * static_[3])));
  if (started_) {
    for (const Creep& c : creep_) v += c.coefficient * (c.x + c.alpha * (angle - c.x) - angle);
    const double step = angle - stop_input_;
    for (const Stop& s : stops_) v += s.coefficient * stop_operator(s.s, step, s.r);
    for (const Relay& r : relays_) v += r.coefficient * relay_step(r.r, angle, r.alpha, r.beta);
  }  // before the first angle: creep relaxed (x_0 = A_0), stop operators at 0, relays unset: no voltage
  if (!rate_.empty()) {
    const double w = std::isfinite(velocity_rad_s) ? std::abs(velocity_rad_s) : 0.0;
    const double sign = d == Direction::kFlexion ? 1.0 : d == Direction::kExtension ? -1.0 : 0.0;
    const double paper = model_voltage(paper_, angle, w, d) - quasi_static_voltage(paper_, angle);
    const double shape = sign * std::sin(kPi * angle / 90.0);
    for (const RateHysteresis& r : rate_) v += r.c_shape * shape * (1.0 - std::exp(-w / r.w0)) + r.c_paper * paper;
  }
  v += acceleration_voltage();
  if (source_) {
    const int size = static_cast<int>(ref_.size());
    // The last size - 1 committed reference voltages and this scan's: the causal 1 s mean.
    const int back = std::min(ref_count_, size - 1);
    double sum = ref_sum_;
    if (ref_count_ == size) sum -= ref_[static_cast<std::size_t>((ref_head_ + 1) % size)];  // the oldest drops out
    const double mean = (sum + reference_v) / (back + 1);
    const double r = mean / reference_level_v_ - 1.0;
    v += c_source_vq_ * quasi_static_voltage(paper_, angle) * r + c_source_r_ * r;
  }
  return v;
}

double GapCorrector::acceleration_voltage() const noexcept { return accel_v_; }

double GapCorrector::estimate_acceleration_voltage() const noexcept {
  double v = 0;
  const int size = static_cast<int>(hist_.size());
  for (const Acceleration& a : accel_) {
    if (hist_count_ < a.n) continue;  // no estimate until the window has filled
    // The quadratic fit's a = 2 c / dt^2 over the newest n committed angles [deg/s^2].
    const double s = acceleration_estimate(a.weights, [&](std::size_t back) {
      const std::size_t at = (static_cast<std::size_t>(hist_head_) + static_cast<std::size_t>(size) - back) %
                             static_cast<std::size_t>(size);
      return hist_[at];
    });
    v += a.coefficient * s * kRadPerDeg;
  }
  return v;
}

double GapCorrector::advance(double angle, double reference_v, double angle_per_volt, double play_angle,
                             bool extrapolate) noexcept {
  if (!active_) {
    kin_ = {angle, angle, angle};
    return angle;
  }
  const double open = accel_.empty() || angle_per_volt == 0 ? angle : angle + angle_per_volt * accel_v_;
  for (Creep& c : creep_) c.x = started_ ? c.x + c.alpha * (angle - c.x) : angle;
  // The stop operators and relays move on the low-passed angle (kMemoryInputTauS): committed on the
  // angle itself, an operator left at its threshold by a movement ratcheted with the noise on its
  // sliding side and walked across its width through a hold (docs/calibration.md, "[gap]"), and a
  // relay would switch on a noise peak the joint never reached.
  const double input = started_ ? stop_input_ + memory_smooth_ * (angle - stop_input_) : angle;
  const double step = started_ ? input - stop_input_ : 0.0;
  for (Stop& s : stops_) s.s = stop_operator(s.s, step, s.r);
  for (Relay& r : relays_) r.r = started_ ? relay_step(r.r, input, r.alpha, r.beta) : relay_start(input, r.centre);
  stop_input_ = input;
  started_ = true;
  const int hsize = static_cast<int>(hist_.size());
  hist_head_ = (hist_head_ + 1) % hsize;
  hist_[static_cast<std::size_t>(hist_head_)] = open;
  hist_count_ = std::min(hist_count_ + 1, hsize);
  if (!accel_.empty()) accel_v_ = estimate_acceleration_voltage();  // for the next scan
  if (source_ && std::isfinite(reference_v)) {
    const int size = static_cast<int>(ref_.size());
    ref_head_ = (ref_head_ + 1) % size;
    double& slot = ref_[static_cast<std::size_t>(ref_head_)];
    ref_sum_ += reference_v - (ref_count_ == size ? slot : 0.0);
    slot = reference_v;
    ref_count_ = std::min(ref_count_ + 1, size);
    if (++ref_since_refresh_ >= kRefreshScans) {
      ref_since_refresh_ = 0;
      ref_sum_ = 0;
      for (int i = 0; i < ref_count_; ++i) ref_sum_ += ref_[static_cast<std::size_t>((ref_head_ - i + size) % size)];
    }
  }
  // Kinematics: the delay first (the fibre sees the joint late), then the belt's play between the
  // joint and the reference.
  double joint = angle;
  if (late_scans_ > 0) {
    const int size = static_cast<int>(late_.size());
    late_head_ = (late_head_ + 1) % size;
    late_[static_cast<std::size_t>(late_head_)] = angle;
    late_count_ = std::min(late_count_ + 1, size);
    // The angle late_scans_ scans ago, interpolated linearly; the oldest one until that far back exists.
    const double back = std::min(late_scans_, static_cast<double>(late_count_ - 1));
    const int i0 = static_cast<int>(std::floor(back));
    const double f = back - i0;
    const double a0 = late_[static_cast<std::size_t>((late_head_ - i0 + size) % size)];
    const double a1 = f > 0 ? late_[static_cast<std::size_t>((late_head_ - i0 - 1 + size) % size)] : a0;
    joint = (1 - f) * a0 + f * a1;
  } else {
    joint = lead_.step(angle);
    if (!extrapolate) joint = angle;
  }
  kin_ = {angle, joint, joint};
  if (half_play_ > 0) {
    // The side is decided on the low-passed angle, the offset applied to the angle itself
    // (kMemoryInputTauS). Fed the angle directly, the play rides the noise's peaks in every hold
    // (the belt sees the joint, not the noise) and ends each hold up to the noise's peak off
    // (measured on the blind benchmark: docs/calibration.md, "[gap]", Backlash).
    const double belt = std::isfinite(play_angle) ? play_angle + (joint - angle) : joint;
    play_input_ = play_started_ ? play_input_ + memory_smooth_ * (belt - play_input_) : belt;
    play_ = play_started_ ? play_operator(play_, play_input_, half_play_) : play_input_;
    play_started_ = true;
    kin_.reference = joint + (play_ - play_input_);
  }
  return kin_.reference;
}

void GapCorrector::interrupt() noexcept {
  hist_count_ = 0;
  accel_v_ = 0;
  late_count_ = 0;
  lead_.reset();
  for (Notch& n : notches_) n.primed = false;
}

void GapCorrector::reset() noexcept {
  interrupt();
  started_ = false;
  for (Stop& s : stops_) s.s = 0;  // unloaded; creep relaxes, relays restart demagnetised and the play
                                   // centres at the next angle
  ref_count_ = 0;
  ref_sum_ = 0;
  ref_since_refresh_ = 0;
  play_started_ = false;
}

}  // namespace pof::core
