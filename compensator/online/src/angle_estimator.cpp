#include "pof/core/angle_estimator.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>

namespace pof::core {

const char* EstimatorNoise::invalid_reason() const {
  if (!(voltage_noise_v > 0) || !std::isfinite(voltage_noise_v)) return "voltage_noise_v must be finite and > 0";
  if (!(acceleration_noise_deg_s2 > 0) || !std::isfinite(acceleration_noise_deg_s2))
    return "acceleration_noise_deg_s2 must be finite and > 0";
  return "";
}

AngleEstimator::AngleEstimator(const DynamicModel& m, const EstimatorNoise& n, double scan_rate_hz, int lag_scans)
    : k_(m, scan_rate_hz), inverse_(m, scan_rate_hz), bend_lag_s_(m.bend_lag_s), lag_(std::clamp(lag_scans, 0, kMaxSmootherLag)) {
  const double dt = 1.0 / scan_rate_hz;
  r_ = n.voltage_noise_v * n.voltage_noise_v;
  q_ = n.acceleration_noise_deg_s2 * n.acceleration_noise_deg_s2;
  // theta' = theta + dt omega (+ dt^2/2 a), omega' = omega (+ dt a); the lag as BendLag: it decays
  // and grows with the angle's increment.
  double decay = 0, gain = 0;
  if (m.bend_lag_s > 0) {
    decay = std::exp(-dt / m.bend_lag_s);
    gain = m.bend_lag_s / dt * (1.0 - decay);
  }
  f_ << 1, dt, 0, 0, 1, 0, 0, gain * dt, decay;
  g_ << 0.5 * dt * dt, dt, gain * 0.5 * dt * dt;
  nis_alpha_ = 1.0 - std::exp(-dt / kAdaptTimeS);
  divergence_run_ = std::max(3, static_cast<int>(std::lround(kDivergenceRunS * scan_rate_hz)));
}

void AngleEstimator::reset() noexcept {
  memory_ = {};
  started_ = false;
  filled_ = 0;
}

// The direct inverse at the current memory, an angle at rest: the rate is unknown (a knee may be
// moving at several rad/s), so its variance is wide and the first few scans settle it.
void AngleEstimator::start(double v, Result& r) noexcept {
  const DynamicInverter::Result inv = inverse_.solve(memory_, v);
  const double theta_f = inv.fibre_angle_deg;
  double slope = 0;
  if (memory_.started) (void)k_.voltage_at(memory_, theta_f, &slope);
  else slope = k_.model.quasi_static_slope(theta_f);
  constexpr double kStartRateSigmaDegS = 200;  // about 3.5 rad/s: gait's fastest knee
  const double sigma_theta = std::sqrt(r_) / std::max(std::abs(slope), 1e-6);
  x_ << theta_f, 0, 0;
  p_.setZero();
  p_(0, 0) = sigma_theta * sigma_theta;
  p_(1, 1) = kStartRateSigmaDegS * kStartRateSigmaDegS;
  if (bend_lag_s_ > 0) p_(2, 2) = std::pow(bend_lag_s_ * kStartRateSigmaDegS, 2);
  k_.advance(memory_, theta_f);
  started_ = true;
  beyond_gate_ = 0;
  nis_mean_ = 1;
  q_scale_ = 1;
  filled_ = 0;
  remember(x_, p_);
  r.restarted = true;
  r.clamped = inv.clamped;
}

void AngleEstimator::remember(const Vec& x_pred, const Mat& p_pred) noexcept {
  if (lag_ == 0) return;
  head_ = head_ == lag_ ? 0 : head_ + 1;
  Slot& s = history_[static_cast<std::size_t>(head_)];
  s.x_filt = x_;
  s.p_filt = p_;
  s.x_pred = x_pred;
  s.p_pred = p_pred;
  if (filled_ <= lag_) ++filled_;
}

// The fixed-lag RTS pass over the ring (Sarkka 2013, eq. 8.2): from the newest filtered state back
// to the oldest slot, which is published. Until the ring holds lag_ + 1 scans since a (re)start
// there is no scan lag_ back to publish: NaN, so that the delay is always exactly lag_ scans.
void AngleEstimator::publish(Result& r) const noexcept {
  if (lag_ > 0 && filled_ <= lag_) {
    r.angle_deg = r.rate_deg_s = r.sigma_deg = std::nan("");
    return;
  }
  Vec xs = x_;
  Mat ps = p_;
  const int n = lag_;
  const bool lagged = bend_lag_s_ > 0;
  for (int i = 0, j = head_; i < n; ++i) {
    const Slot& next = history_[static_cast<std::size_t>(j)];
    j = j == 0 ? lag_ : j - 1;
    const Slot& cur = history_[static_cast<std::size_t>(j)];
    Mat gain = Mat::Zero();
    if (lagged) {
      gain = cur.p_filt * f_.transpose() * next.p_pred.inverse();
    } else {  // the lag's row and column are zero: invert the angle-rate block alone
      gain.topLeftCorner<2, 2>() =
          cur.p_filt.topLeftCorner<2, 2>() * f_.topLeftCorner<2, 2>().transpose() * next.p_pred.topLeftCorner<2, 2>().inverse();
    }
    xs = cur.x_filt + gain * (xs - next.x_pred);
    ps = cur.p_filt + gain * (ps - next.p_pred) * gain.transpose();
  }
  r.angle_deg = xs(0);
  r.rate_deg_s = xs(1);
  r.sigma_deg = std::sqrt(std::max(ps(0, 0), 0.0));
}

AngleEstimator::Result AngleEstimator::step(double v) noexcept {
  Result r;
  if (!started_) {
    if (!std::isfinite(v)) {
      r.angle_deg = r.rate_deg_s = r.sigma_deg = std::nan("");
      return r;
    }
    start(v, r);
    publish(r);
    return r;
  }
  const Vec x_pred = f_ * x_;
  const Mat p_pred = f_ * p_ * f_.transpose() + q_ * q_scale_ * g_ * g_.transpose();
  const double lo = inverse_.lower_deg(), hi = inverse_.upper_deg();
  x_ = x_pred;
  p_ = p_pred;
  if (std::isfinite(v)) {
    // Iterated EKF: relinearise h at the last iterate; the innovation and its variance are the
    // first iterate's (at the prediction), which is what the chi-square gate judges.
    Vec x = x_pred;
    Vec k = Vec::Zero();
    Eigen::RowVector3d h = Eigen::RowVector3d::Zero();
    for (int it = 0; it < kIterations; ++it) {
      const double theta_f = std::clamp(x(0) - x(2), lo, hi);
      double slope = 0;
      const double v_model = k_.voltage_at(memory_, theta_f, &slope);
      h << slope, 0, -slope;
      const double s = (h * p_pred * h.transpose())(0, 0) + r_;
      k = p_pred * h.transpose() / s;
      const double innovation = v - v_model;
      if (it == 0) r.nis = innovation * innovation / s;
      const Vec next = x_pred + k * (innovation - (h * (x_pred - x))(0, 0));
      const bool converged = std::abs(next(0) - x(0)) < 1e-6;
      x = next;
      if (converged) break;
    }
    // Joseph form: stays symmetric and positive under rounding.
    const Mat a = Mat::Identity() - k * h;
    p_ = a * p_pred * a.transpose() + r_ * k * k.transpose();
    x_ = x;
    beyond_gate_ = r.nis > kNisGate ? beyond_gate_ + 1 : 0;
    // Process noise raised while the innovations are larger than the filter expects (a knee
    // accelerating more than sigma_a allows): their fading-memory mean over kAdaptTimeS scales Q,
    // Bar-Shalom, Li, Kirubarajan (2001), sec. 11.2 (continuous noise level adjustment).
    nis_mean_ += nis_alpha_ * (r.nis - nis_mean_);
    q_scale_ = std::clamp(nis_mean_, 1.0, kMaxNoiseScale);
    if (beyond_gate_ >= divergence_run_ || !x_.allFinite()) {
      ++divergences_;
      start(v, r);
      publish(r);
      return r;
    }
  }
  const double theta_f = x_(0) - x_(2);
  r.clamped = theta_f <= lo || theta_f >= hi;
  k_.advance(memory_, std::clamp(theta_f, lo, hi));
  remember(x_pred, p_pred);
  publish(r);
  return r;
}

}  // namespace pof::core
