#include "pof/core/dynamic_model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Dense>

#include "pof/core/units.hpp"

namespace pof::core {

namespace {
}  // namespace

double DynamicModel::quasi_static_v(double theta_deg) const {
  const double x = (theta_deg - angle_centre_deg) / angle_scale_deg;
  double v = 0;
  for (int k = degree; k >= 0; --k) v = v * x + poly[static_cast<std::size_t>(k)];  // Horner
  return v;
}

double DynamicModel::quasi_static_slope(double theta_deg) const {
  const double x = (theta_deg - angle_centre_deg) / angle_scale_deg;
  double d = 0;
  for (int k = degree; k >= 1; --k) d = d * x + k * poly[static_cast<std::size_t>(k)];
  return d / angle_scale_deg;
}

double DynamicModel::rate_factor(double speed_rad_s) const {
  const double w = std::min(std::abs(speed_rad_s), speed_limit_rad_s);
  return rate_gain_s_per_rad >= 0 ? 1.0 + rate_gain_s_per_rad * w : 1.0 / (1.0 - rate_gain_s_per_rad * w);
}

double DynamicModel::loop_half_height_v() const {
  double h = 0;
  for (int i = 0; i < n_operators; ++i) h += weight_v_per_deg[static_cast<std::size_t>(i)] * threshold_deg[static_cast<std::size_t>(i)];
  return h;
}

const char* DynamicModel::invalid_reason() const {
  if (degree < 1 || degree > kMaxDegree) return "degree must be 1..5";
  if (n_operators < 0 || n_operators > kMaxOperators) return "at most 16 hysteresis operators";
  if (n_prony < 0 || n_prony > kMaxPronyTerms) return "at most 8 Prony terms";
  if (!std::isfinite(angle_centre_deg) || !(angle_scale_deg > 0) || !std::isfinite(angle_scale_deg))
    return "angle_centre_deg must be finite and angle_scale_deg > 0";
  if (!std::isfinite(angle_min_deg) || !std::isfinite(angle_max_deg) || !(angle_max_deg > angle_min_deg))
    return "the angle range must be finite with angle_max_deg > angle_min_deg";
  for (int k = 0; k <= degree; ++k)
    if (!std::isfinite(poly[static_cast<std::size_t>(k)])) return "the polynomial coefficients must be finite";
  if (!(quasi_static_slope(0.5 * (angle_min_deg + angle_max_deg)) != 0)) return "the quasi-static polynomial is flat";
  int pos = 0, neg = 0;
  for (int i = 0; i < n_operators; ++i) {
    const auto u = static_cast<std::size_t>(i);
    if (!(threshold_deg[u] > 0) || !std::isfinite(threshold_deg[u])) return "operator thresholds must be finite and > 0";
    if (!std::isfinite(weight_v_per_deg[u])) return "operator weights must be finite";
    pos += weight_v_per_deg[u] > 0;
    neg += weight_v_per_deg[u] < 0;
  }
  if (pos > 0 && neg > 0) return "operator weights must share one sign (the inverse needs a monotone branch)";
  if (!std::isfinite(rate_gain_s_per_rad)) return "rate_gain_s_per_rad must be finite";
  if (!(speed_filter_s > 0) || !std::isfinite(speed_filter_s)) return "speed_filter_s must be > 0";
  if (!(speed_limit_rad_s >= 0) || !std::isfinite(speed_limit_rad_s)) return "speed_limit_rad_s must be >= 0";
  if (!(bend_lag_s >= 0 && bend_lag_s <= 2)) return "bend_lag_s must be within 0..2 s";
  if (!(lag_window_s > 0 && lag_window_s <= 1)) return "lag_window_s must be within (0, 1] s";
  for (int j = 0; j < n_prony; ++j) {
    const auto u = static_cast<std::size_t>(j);
    if (!(prony_tau_s[u] > 0) || !std::isfinite(prony_tau_s[u])) return "Prony time constants must be finite and > 0";
    if (!std::isfinite(prony_gain_v_per_deg[u])) return "Prony gains must be finite";
  }
  return "";
}

BendLag::BendLag(double tau_s, double scan_rate_hz) : on_(tau_s > 0) {
  if (!on_) return;
  const double dt = 1.0 / scan_rate_hz;
  decay_ = std::exp(-dt / tau_s);
  gain_ = tau_s / dt * (1.0 - decay_);
}

double BendLag::step(double theta) noexcept {
  if (!on_) return theta;
  // lag = theta - theta_f obeys lag' = theta' - lag / tau_b: decays, and grows with the increment.
  lag_ = started_ ? decay_ * lag_ + gain_ * (theta - theta_) : 0.0;
  theta_ = theta;
  started_ = true;
  return theta - lag_;
}

LagInverse::LagInverse(double tau_s, double window_s, double scan_rate_hz) : on_(tau_s > 0) {
  if (!on_) return;
  const double dt = 1.0 / scan_rate_hz;
  n_ = std::clamp(static_cast<int>(std::lround(window_s / dt)) + 1, 5, kMaxLagWindow);
  // Least squares theta_f(u) ~ a + b u + c u^2 over u = -i dt, i = 0..n-1: a + tau_b b at u = 0 is
  // one row of the pseudo-inverse, computed once.
  Eigen::MatrixXd A(n_, 3);
  for (int i = 0; i < n_; ++i) {
    const double u = -i * dt;
    A(i, 0) = 1;
    A(i, 1) = u;
    A(i, 2) = u * u;
  }
  const Eigen::Matrix3d AtA = A.transpose() * A;
  const Eigen::Vector3d e(1.0, tau_s, 0.0);
  const Eigen::VectorXd h = A * AtA.ldlt().solve(e);
  for (int i = 0; i < n_; ++i) h_[static_cast<std::size_t>(i)] = h(i);
}

double LagInverse::step(double theta_f) noexcept {
  if (!on_) return theta_f;
  head_ = head_ == 0 ? n_ - 1 : head_ - 1;  // buf_[head_] is the newest scan
  buf_[static_cast<std::size_t>(head_)] = theta_f;
  if (filled_ < n_) ++filled_;
  if (filled_ < n_) return theta_f;
  double y = 0;
  for (int i = 0, j = head_; i < n_; ++i, j = j + 1 == n_ ? 0 : j + 1)
    y += h_[static_cast<std::size_t>(i)] * buf_[static_cast<std::size_t>(j)];
  return y;
}

double LagInverse::noise_gain() const noexcept {
  if (!on_) return 1.0;
  double s = 0;
  for (int i = 0; i < n_; ++i) s += h_[static_cast<std::size_t>(i)] * h_[static_cast<std::size_t>(i)];
  return std::sqrt(s);
}

DynamicKernel::DynamicKernel(const DynamicModel& m, double scan_rate_hz) : model(m), dt_s(1.0 / scan_rate_hz) {
  for (int j = 0; j < m.n_prony; ++j) {
    const auto u = static_cast<std::size_t>(j);
    decay[u] = std::exp(-dt_s / m.prony_tau_s[u]);
    ramp_gain[u] = m.prony_tau_s[u] / dt_s * (1.0 - decay[u]);
  }
  speed_alpha = 1.0 - std::exp(-dt_s / m.speed_filter_s);
}

double DynamicKernel::speed_rad_s(const DynamicState& s) const { return std::abs(s.speed_f2) * kRadPerDeg; }

double DynamicKernel::voltage_at(const DynamicState& s, double theta, double* dv) const {
  const DynamicModel& m = model;
  // Before the first scan there is no increment: the memory terms are constant (0) in theta.
  const double d = s.started ? theta - s.angle_deg : 0.0;
  const double dd = s.started ? 1.0 : 0.0;
  const double phi = m.rate_factor(speed_rad_s(s));
  double v = m.quasi_static_v(theta), slope = m.quasi_static_slope(theta);
  double hyst = 0, hyst_slope = 0;
  for (int i = 0; i < m.n_operators; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const double r = m.threshold_deg[u];
    const double z = stop_operator(s.stop[u], d, r);
    hyst += m.weight_v_per_deg[u] * z;
    if (z > -r && z < r) hyst_slope += m.weight_v_per_deg[u];  // elastic: moves with theta
  }
  v += phi * hyst;
  slope += dd * phi * hyst_slope;
  for (int j = 0; j < m.n_prony; ++j) {
    const auto u = static_cast<std::size_t>(j);
    v += m.prony_gain_v_per_deg[u] * (s.prony[u] * decay[u] + ramp_gain[u] * d);
    slope += dd * m.prony_gain_v_per_deg[u] * ramp_gain[u];
  }
  if (dv != nullptr) *dv = slope;
  return v;
}

void DynamicKernel::advance(DynamicState& s, double theta) const {
  const DynamicModel& m = model;
  const double d = s.started ? theta - s.angle_deg : 0.0;
  for (int i = 0; i < m.n_operators; ++i) {
    const auto u = static_cast<std::size_t>(i);
    s.stop[u] = stop_operator(s.stop[u], d, m.threshold_deg[u]);
  }
  for (int j = 0; j < m.n_prony; ++j) {
    const auto u = static_cast<std::size_t>(j);
    s.prony[u] = s.prony[u] * decay[u] + ramp_gain[u] * d;
  }
  // Two cascaded first-order filters of the angle rate: the second removes most of what the
  // differentiation lets through (angle noise of sigma gives ~sigma sqrt(alpha^3/2)/dt).
  const double rate = d / dt_s;
  s.speed_f1 += speed_alpha * (rate - s.speed_f1);
  s.speed_f2 += speed_alpha * (s.speed_f1 - s.speed_f2);
  s.angle_deg = theta;
  s.started = true;
}

double DynamicKernel::forward(DynamicState& s, double theta) const {
  const double v = voltage_at(s, theta, nullptr);
  advance(s, theta);
  return v;
}

DynamicInverter::DynamicInverter(const DynamicModel& m, double scan_rate_hz)
    : k_(m, scan_rate_hz), lag_(m.bend_lag_s, m.lag_window_s, scan_rate_hz) {
  const double span = m.angle_max_deg - m.angle_min_deg;
  lo_ = m.angle_min_deg - 0.25 * span;
  hi_ = m.angle_max_deg + 0.25 * span;
  sign_ = m.quasi_static_slope(0.5 * (m.angle_min_deg + m.angle_max_deg)) < 0 ? -1.0 : 1.0;
}

DynamicInverter::Result DynamicInverter::step(double v) noexcept {
  Result r;
  if (!std::isfinite(v)) {
    r.angle_deg = r.fibre_angle_deg = std::nan("");
    lag_.reset();  // its window would span the gap
    return r;
  }
  r = solve(state_, v);
  r.angle_deg = lag_.step(r.fibre_angle_deg);
  k_.advance(state_, r.fibre_angle_deg);
  return r;
}

DynamicInverter::Result DynamicInverter::solve(const DynamicState& state, double v) const noexcept {
  Result r;
  // f(theta) = sign * (V(theta) - v) is increasing in theta; keep a bracket [a, b] with f(a) < 0 < f(b)
  // as it is learnt, Newton inside it, bisection when Newton leaves it or stalls.
  double a = lo_, b = hi_;
  double theta = state.started ? std::clamp(state.angle_deg, a, b) : 0.5 * (a + b);
  bool a_known = false, b_known = false;
  constexpr int kMaxIterations = 60;
  constexpr double kTolDeg = 1e-7;
  for (r.iterations = 1; r.iterations <= kMaxIterations; ++r.iterations) {
    double slope = 0;
    const double f = sign_ * (k_.voltage_at(state, theta, &slope) - v);
    slope *= sign_;
    if (f == 0) break;
    if (f < 0) {
      a = theta;
      a_known = true;
    } else {
      b = theta;
      b_known = true;
    }
    double next = slope > 0 ? theta - f / slope : std::nan("");
    const bool inside = next > a && next < b;
    if (!inside) {
      // Outside the bracket: halve it where both ends are known, else step to the unknown end.
      if (a_known && b_known) next = 0.5 * (a + b);
      else next = f < 0 ? b : a;
    }
    if (std::abs(next - theta) < kTolDeg) {
      theta = next;
      break;
    }
    if (!a_known && f > 0 && theta <= lo_) break;  // below the range: stays at the lower bound
    if (!b_known && f < 0 && theta >= hi_) break;  // above the range
    theta = next;
  }
  r.clamped = theta <= lo_ || theta >= hi_;
  r.fibre_angle_deg = r.angle_deg = theta;
  return r;
}

}  // namespace pof::core
