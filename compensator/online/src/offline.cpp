#include "pof/core/offline.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pof::core {

double median_step_s(const Eigen::VectorXd& t) {
  if (t.size() < 2) return 0;
  std::vector<double> d(static_cast<std::size_t>(t.size() - 1));
  for (Eigen::Index i = 1; i < t.size(); ++i) d[static_cast<std::size_t>(i - 1)] = t(i) - t(i - 1);
  auto mid = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
  std::nth_element(d.begin(), mid, d.end());
  return *mid > 0 ? *mid : 0;
}

double median_rate_hz(const Eigen::VectorXd& t) {
  const double dt = median_step_s(t);
  return dt > 0 ? 1.0 / dt : 0;
}

OfflineResult compensate_recording(const Eigen::VectorXd& t_s, const Eigen::VectorXd& sensor_v,
                                   const Eigen::VectorXd& reference_v, const Eigen::VectorXd& angle_ref_deg,
                                   const Calibration& cal, CompensatorSettings settings,
                                   const StatisticsSettings& stats_settings,
                                   const std::function<void(Eigen::Index, Eigen::Index)>& progress) {
  const Eigen::Index n = t_s.size();
  if (sensor_v.size() != n || reference_v.size() != n || (angle_ref_deg.size() != 0 && angle_ref_deg.size() != n))
    throw std::invalid_argument("compensate_recording: columns differ in length");
  OfflineResult r;
  r.scan_rate_hz = median_rate_hz(t_s);
  if (r.scan_rate_hz > 0) settings.scan_rate_hz = r.scan_rate_hz;
  const bool have_ref = angle_ref_deg.size() == n;
  if (settings.velocity_source == VelocitySource::kReference && !have_ref)
    throw std::invalid_argument("the reference velocity source needs a reference angle");
  OnlineCompensator comp(cal, settings);
  CycleStatistics stats(stats_settings);
  r.angle_deg.resize(n);
  r.angle_uncomp_deg.resize(n);
  r.velocity_rad_s.resize(n);
  r.phase.resize(static_cast<std::size_t>(n));
  r.quality.resize(static_cast<std::size_t>(n));
  const double lost_after_s = 1.5 / settings.scan_rate_hz;
  const double nan = std::nan("");
  // With the estimator's fixed lag step() describes the scan lag back: its row is that scan's. The
  // last lag rows have no output (NaN, settling).
  const Eigen::Index lag = comp.lag_scans();
  for (Eigen::Index i = n - std::min(lag, n); i < n; ++i) {
    r.angle_deg(i) = r.angle_uncomp_deg(i) = r.velocity_rad_s(i) = nan;
    r.phase[static_cast<std::size_t>(i)] = Direction::kHold;
    r.quality[static_cast<std::size_t>(i)] = quality::kSettling;
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    if (i > 0 && t_s(i) - t_s(i - 1) > lost_after_s) {
      comp.reset();
      ++r.resets;
    }
    const double ref = have_ref ? angle_ref_deg(i) : nan;
    const CompensatedScan s = comp.step(sensor_v(i), reference_v(i), ref);
    const Eigen::Index row = i - lag;
    if (row < 0) continue;
    r.angle_deg(row) = s.angle_deg;
    r.angle_uncomp_deg(row) = s.angle_uncomp_deg;
    r.velocity_rad_s(row) = s.velocity_rad_s;
    r.phase[static_cast<std::size_t>(row)] = s.phase;
    r.quality[static_cast<std::size_t>(row)] = s.quality;
    if (have_ref && stats.add(t_s(row), s, angle_ref_deg(row))) r.cycles.push_back(stats.last());
    if (progress && (i % 4096) == 0) progress(i, n);
  }
  if (have_ref && stats.finish()) r.cycles.push_back(stats.last());
  if (progress) progress(n, n);
  r.overall = stats.overall();
  r.profile = stats.profile();
  r.cycles_dropped = stats.cycles_dropped();
  return r;
}

}  // namespace pof::core
