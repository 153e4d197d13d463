#pragma once
// Per-cycle statistics as in table 3 of Leal-Junior et al. 2017: RMSE against the reference
// (potentiometer) and hysteresis by eq. (1), with and without compensation, the largest error, and
// the error-versus-angle profile of figure 12. Incremental and allocation-free, so pof compensate
// (offline) and pof-compensatord (online, cycle_stats_t) run the same code on the same scans.
//
// A cycle is a flexion sweep followed by an extension sweep, in the phases the compensator decided;
// it closes when the next flexion starts, after a hold of close_after_hold_s that follows its
// extension, or at finish(). Holds are not part of a cycle (they use
// f5 only). A cycle is kept when both sweeps have min_samples scans and span min_span_deg of the
// reference; a partial cycle at the start or end of a recording is dropped and counted.
// eq. (1) here: x = reference angle, y = sensor angle; lines fitted per sweep (running sums).
#include <array>
#include <cstdint>
#include <limits>

#include "pof/core/compensator.hpp"
#include "pof/core/fit.hpp"

namespace pof::core {

struct StatisticsSettings {
  double min_span_deg = 20.0;
  std::int64_t min_samples = 20;
  // A hold this long after the extension sweep closes the cycle: its statistics are complete (holds
  // are not part of a cycle), and a live stream must not wait for the next flexion, which may never
  // come (the last cycle of a session). 0 = close only at the next flexion or at finish().
  double close_after_hold_s = 2.0;
};

struct CycleStats {
  int cycle = 0;                 // from 1
  double t_start_s = 0, t_end_s = 0;
  double velocity_rad_s = 0;     // mean of the two sweeps' |slope| of reference angle against time
  double rmse_comp_deg = 0, rmse_uncomp_deg = 0;
  double hysteresis_comp_pct = 0, hysteresis_uncomp_pct = 0;  // |eq. (1)|
  double max_error_deg = 0;      // max |compensated - reference|
  double max_error_angle_deg = 0;  // reference angle where it occurred
  std::int64_t n_samples = 0;
};

/// Figure 12: error against the reference angle, in fixed bins [0, 90) deg of 5 deg.
struct ErrorProfile {
  static constexpr int kBins = 18;
  static constexpr double kBinDeg = 5.0;
  std::array<double, kBins> sum_comp{}, sum_uncomp{}, sum_abs_comp{}, sum_abs_uncomp{};
  std::array<std::int64_t, kBins> count{};

  void add(double angle_ref_deg, double err_comp, double err_uncomp);
  [[nodiscard]] static double centre(int bin) { return (bin + 0.5) * kBinDeg; }
};

class CycleStatistics {
 public:
  explicit CycleStatistics(const StatisticsSettings& s = {}) : s_(s) {}

  /// One compensated scan with its reference angle. Returns true when this scan closed a valid
  /// cycle; last() then holds it. NaN angles or references are skipped. Hold scans only time the
  /// hold that closes a finished cycle.
  bool add(double t_s, const CompensatedScan& scan, double angle_ref_deg) noexcept;
  /// Closes the cycle in progress (end of a recording). Returns true if it was valid.
  bool finish() noexcept;

  [[nodiscard]] const CycleStats& last() const noexcept { return last_; }
  /// Over every kept cycle: RMSE pooled over their scans, velocity and hysteresis the mean of the
  /// cycles', max error the largest; cycle = number of cycles kept.
  [[nodiscard]] CycleStats overall() const noexcept;
  [[nodiscard]] const ErrorProfile& profile() const noexcept { return profile_; }
  [[nodiscard]] int cycles_kept() const noexcept { return kept_; }
  [[nodiscard]] int cycles_dropped() const noexcept { return dropped_; }

 private:
  struct Current {
    LineAccumulator comp[2], uncomp[2];  // [0] flexion, [1] extension: y = angle, x = reference
    LineAccumulator speed[2];            // x = t, y = reference angle: the sweep's velocity
    double sq_comp = 0, sq_uncomp = 0, max_err = 0, max_err_angle = 0;
    double t_start = 0, t_end = 0;
    std::int64_t n = 0;
    bool seen_extension = false;
    double hold_since = -1;  // start of the hold that follows the extension [s]; -1 = none
  };
  bool close() noexcept;

  StatisticsSettings s_;
  Current cur_;
  CycleStats last_;
  ErrorProfile profile_;
  int kept_ = 0, dropped_ = 0;
  double tot_sq_comp_ = 0, tot_sq_uncomp_ = 0, tot_w_ = 0, tot_h_comp_ = 0, tot_h_uncomp_ = 0, tot_max_ = 0;
  std::int64_t tot_n_ = 0;
};

}  // namespace pof::core
