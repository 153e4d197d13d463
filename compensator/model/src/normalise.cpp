#include "pof/core/normalise.hpp"

#include <algorithm>
#include <limits>
#include <vector>

#include "pof/core/potentiometer.hpp"

namespace pof::core {

Eigen::VectorXd normalise(const Eigen::VectorXd& sensor_v, const Eigen::VectorXd& reference_v,
                          const ReferenceGuard& g, Eigen::Index* n_rejected) {
  const Eigen::Index n = std::min(sensor_v.size(), reference_v.size());
  Eigen::VectorXd out(n);
  Eigen::Index rejected = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Normalised s = normalise(sensor_v(i), reference_v(i), g);
    out(i) = s.v;
    if (!s.ok) ++rejected;
  }
  if (n_rejected) *n_rejected = rejected;
  return out;
}

double reference_level(const Eigen::VectorXd& reference_v) {
  std::vector<double> v;
  v.reserve(static_cast<std::size_t>(reference_v.size()));
  for (const double r : reference_v)
    if (std::isfinite(r) && r > 0) v.push_back(r);
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

double PotentiometerCalibration::angle(double pot_v) const {
  const double a = deg_per_volt * (pot_v - zero_v);
  if (offsets.empty() || !std::isfinite(a)) return a;
  if (a <= offsets.front().first) return a + offsets.front().second;
  if (a >= offsets.back().first) return a + offsets.back().second;
  const auto hi = std::upper_bound(offsets.begin(), offsets.end(), a,
                                   [](double x, const std::pair<double, double>& p) { return x < p.first; });
  const auto lo = hi - 1;
  const double f = (a - lo->first) / (hi->first - lo->first);
  return a + lo->second + f * (hi->second - lo->second);
}

Eigen::VectorXd PotentiometerCalibration::angles(const Eigen::VectorXd& pot_v) const {
  Eigen::VectorXd out(pot_v.size());
  for (Eigen::Index i = 0; i < pot_v.size(); ++i) out(i) = angle(pot_v(i));
  return out;
}

}  // namespace pof::core
