#include "pof/core/step_detector.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "pof/core/compensator.hpp"

namespace pof::core {

StepDetector::StepDetector(const ModelCoefficients& model, double velocity_min_rad_s, const CompensatorSettings& s,
                           int window_scans)
    : model_(model),
      velocity_min_rad_s_(velocity_min_rad_s),
      tolerance_(s.step_tolerance),
      min_snr_(s.step_min_snr),
      min_deg_(s.step_min_deg),
      n_(window_scans) {
  if (!(s.step_block_s > 0 && std::isfinite(s.step_block_s)) || !(s.step_tolerance > 0 && s.step_tolerance < 1) ||
      !(s.step_min_snr > 0 && std::isfinite(s.step_min_snr)) || !(s.step_min_deg >= 0 && std::isfinite(s.step_min_deg)) ||
      !(s.reversal_rad_s > s.move_rad_s))
    throw std::invalid_argument(
        "compensator: model steps need a finite step_block_s > 0, 0 < step_tolerance < 1, finite step_min_snr > 0 "
        "and step_min_deg >= 0, and reversal_rad_s > move_rad_s");
  // A block of at least 3 scans (of 2, one noisy scan past the line would be a step), and the
  // block and the 3 before it must fit the window; otherwise model steps are off (a velocity
  // window under 0.06 s at 200 Hz).
  const double block = std::max(3.0, std::round(s.step_block_s * s.scan_rate_hz));
  if (4 * block <= n_) {
    m_ = static_cast<int>(block);
    scratch_.assign(static_cast<std::size_t>(4 * m_), 0.0);
  }
}

double StepDetector::predicted_step(double angle, Direction from, Direction to) const noexcept {
  // B_d(A) = f5(V_d(A, w_min)) - A: where the f5 angle sits on branch d (0 in a hold). The sensor
  // changes branch as its speed passes through the lowest speeds, so the branches are taken there.
  auto offset = [&](Direction d) {
    if (d == Direction::kHold) return 0.0;
    return quasi_static_angle(model_, model_voltage(model_, angle, velocity_min_rad_s_, d)) - angle;
  };
  return offset(to) - offset(from);
}

Direction StepDetector::detect(VelocityWindow& window, Direction phase) noexcept {
  if (m_ == 0 || !window.full()) return phase;
  // The newest scans against the straight line through the 3M angles before the newest block of
  // M: a movement that goes on as before cancels, and so does one whose speed changes no faster
  // than a knee's within those 0.1 s (docs/calibration.md, "Model steps").
  const int m = m_, k = 3 * m;
  double* const x = scratch_.data();  // x[back], newest first
  window.copy_newest(x, m + k);
  double mean = 0, sxy = 0;
  for (int i = 0; i < k; ++i) mean += x[m + i];
  mean /= k;
  const double centre = m + (k - 1) / 2.0;  // the line's centre, in scans back from the newest
  for (int i = 0; i < k; ++i) sxy += (m + i - centre) * (x[m + i] - mean);
  const double sxx = k * (static_cast<double>(k) * k - 1) / 12.0;
  auto past_line = [&](int back) { return x[back] - (mean + sxy / sxx * (back - centre)); };
  // The measured step: the newest M - 1 scans past the line (a step is taken once it is M - 1
  // scans old; the oldest scan of the block may still be from before it).
  double measured = 0;
  for (int i = 0; i < m - 1; ++i) measured += past_line(i);
  measured /= m - 1;
  // Its spread without steps, measured on the statistic itself (noise, a converter's staircase
  // under a slow movement, vibration): a running mean of its square over the first two windows,
  // then an exponential one over four, each square held below 16 times the estimate so that the
  // steps themselves barely count. The cap never goes below 16 (min_deg / min_snr)^2, so that an
  // estimate that learnt zero (a converter that read one code through a still start) still grows
  // once the knee moves (docs/calibration.md, "Model steps").
  const double q = measured * measured;
  if (std::isfinite(q)) {
    const double floor = min_deg_ / min_snr_;
    ++stat_count_;
    const double held = stat_count_ > 2 * n_ ? std::min(q, 16 * std::max(stat_var_, floor * floor)) : q;
    stat_var_ += (held - stat_var_) / static_cast<double>(std::min<std::int64_t>(stat_count_, 4 * static_cast<std::int64_t>(n_)));
  }
  if (stat_count_ < 2 * n_ || hold_ > n_ - m) return phase;  // one step per block
  const double noise = std::sqrt(stat_var_);
  // No prediction can fit a measured step below (1 - tolerance) of the smallest one looked for:
  // most scans end here, before the model's branches are evaluated.
  if (std::abs(measured) < (1 - tolerance_) * std::max(min_snr_ * noise, min_deg_)) return phase;
  const double angle = mean - sxy / sxx * centre + offset_;  // the f5 angle now, without the step
  // A stop (to hold) is taken when it fits; otherwise the nearest prediction, if it fits. Where a
  // stop and a reversal both fit, their steps, and so the angles they give, differ little, and a
  // knee that does turn shows it in the window soon after (the direction detector lets the window
  // name the new direction then). To fit, the prediction must be within the tolerance, large enough
  // to tell from the statistic's spread, and a step, not a few noisy scans: each of the M - 1
  // newest scans more than half of it past the line. Otherwise the next scan tries again.
  auto fits = [&](double p) {
    return std::isfinite(p) && std::abs(p) >= std::max(min_snr_ * noise, min_deg_) &&
           std::abs(measured - p) <= tolerance_ * std::abs(p);
  };
  Direction best = phase;
  double predicted = phase != Direction::kHold ? predicted_step(angle, phase, Direction::kHold) : 0.0;
  if (phase != Direction::kHold && fits(predicted)) {
    best = Direction::kHold;
  } else {
    double best_miss = std::numeric_limits<double>::infinity();
    for (const Direction to : {Direction::kHold, Direction::kFlexion, Direction::kExtension}) {
      const double p = predicted_step(angle, phase, to);
      if (to == phase || !std::isfinite(p) || std::abs(measured - p) >= best_miss) continue;
      best_miss = std::abs(measured - p);
      best = to;
      predicted = p;
    }
    if (best == phase || !fits(predicted)) return phase;
  }
  int run = 0;
  while (run < m && past_line(run) * predicted > 0.5 * predicted * predicted) ++run;
  if (run < m - 1) return phase;
  // The step's scans are moved back by it, and every later angle by the same offset.
  for (int i = 0; i < run; ++i) window.back(i) -= measured;
  offset_ += measured;
  window.refresh();
  hold_ = n_;
  return best;
}

}  // namespace pof::core
