#include "pof/core/estimator_noise.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace pof::core {

EstimatorNoise identify_estimator_noise(const Eigen::VectorXd& t_s, const Eigen::VectorXd& v, const Eigen::VectorXd& angle,
                                        const EstimatorNoiseSettings& s) {
  const std::vector<Segment> segments = segment(t_s, angle, s.segmentation);
  double sum_sq = 0;
  long pairs = 0;
  for (const Segment& g : segments) {
    if (g.kind != Direction::kHold || g.duration_s() < s.min_hold_s) continue;
    for (Eigen::Index i = g.begin + 1; i < g.end; ++i) {
      const double d = v(i) - v(i - 1);
      if (!std::isfinite(d)) continue;
      sum_sq += d * d;
      ++pairs;
    }
  }
  if (pairs < 10)
    throw std::runtime_error("the estimator's voltage noise needs holds of at least " + std::to_string(s.min_hold_s) +
                             " s in the recording; found none");
  EstimatorNoise n;
  n.voltage_noise_v = std::sqrt(sum_sq / (2.0 * static_cast<double>(pairs)));
  if (!(n.voltage_noise_v > 0))
    throw std::runtime_error("the normalised voltage never changes in the holds: its noise cannot be measured");

  const Eigen::VectorXd rate = centred_slope(t_s, angle, s.accel_window_s);
  const Eigen::VectorXd accel = centred_slope(t_s, rate, s.accel_window_s);
  std::vector<double> moving;
  for (const Segment& g : segments) {
    if (g.kind == Direction::kHold) continue;
    for (Eigen::Index i = g.begin; i < g.end; ++i)
      if (std::isfinite(accel(i))) moving.push_back(std::abs(accel(i)));
  }
  if (moving.size() < 10) throw std::runtime_error("the estimator's motion model needs movement in the recording; found none");
  const auto p99 = moving.begin() + static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(moving.size() - 1));
  std::nth_element(moving.begin(), p99, moving.end());
  n.acceleration_noise_deg_s2 = std::max(*p99, s.min_acceleration_deg_s2);
  return n;
}

}  // namespace pof::core
