#pragma once
// A whole recording through the online path: OnlineCompensator one scan at a time (what
// pof-compensatord does per scan) and CycleStatistics on the reference angle. `pof compensate`
// and the calibration report use it, so offline figures are the daemon's figures.
#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "pof/core/compensator.hpp"
#include "pof/core/statistics.hpp"

namespace pof::core {

struct OfflineResult {
  Eigen::VectorXd angle_deg, angle_uncomp_deg, velocity_rad_s;
  std::vector<Direction> phase;
  std::vector<std::int32_t> quality;
  std::vector<CycleStats> cycles;
  CycleStats overall;
  ErrorProfile profile;
  int cycles_dropped = 0;
  int resets = 0;          // estimator resets at lost scans
  double scan_rate_hz = 0; // from the median scan interval
};

/// Median time step [s] of a time column (0 with fewer than 2 scans or a median step not > 0).
double median_step_s(const Eigen::VectorXd& t_s);
/// Median scan rate [Hz] of a time column, 1 / median_step_s() (0 with fewer than 2 scans).
double median_rate_hz(const Eigen::VectorXd& t_s);

/// settings.scan_rate_hz is replaced by the recording's median rate. A time step longer than 1.5
/// nominal intervals means lost scans: the estimator is reset (quality::kScansLost on the next scan).
/// angle_ref_deg may be empty (no statistics then). progress(i, n) is called every 4096 scans.
OfflineResult compensate_recording(const Eigen::VectorXd& t_s, const Eigen::VectorXd& sensor_v,
                                   const Eigen::VectorXd& reference_v, const Eigen::VectorXd& angle_ref_deg,
                                   const Calibration& cal, CompensatorSettings settings = {},
                                   const StatisticsSettings& stats = {},
                                   const std::function<void(Eigen::Index, Eigen::Index)>& progress = {});

}  // namespace pof::core
