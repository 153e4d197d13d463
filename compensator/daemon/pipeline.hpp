#pragma once
// The work of pof-compensatord, without the process around it: raw sample blocks in (POF_RAW),
// compensated angles (POF_ANGLE) and per-cycle statistics (POF_STATS) out, through the same
// OnlineCompensator and CycleStatistics that `pof compensate` runs offline.
//
// Deterministic: the output depends only on the sequence of blocks (times come from the blocks,
// never from the clock, except publish_utime), so replaying a log reproduces the live angles bit
// for bit.
//
// Threading: one thread (the LCM handle() thread) calls everything. on_block() never throws and
// allocates only when the scan rate changes (the estimator window is sized by it).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "pof/angle_t.hpp"
#include "pof/compensator_status_t.hpp"
#include "pof/core/compensator.hpp"
#include "pof/core/potentiometer.hpp"
#include "pof/core/statistics.hpp"
#include "pof/cycle_stats_t.hpp"
#include "pof/io/calibration_file.hpp"
#include "pof/raw_block_t.hpp"

namespace pof::compensatord {

struct PipelineSettings {
  std::string sensor_id;
  /// Published angle rate [Hz]; 0 publishes every scan. Otherwise every k = round(scan rate /
  /// output rate) scans one angle_t carries the mean of those k scans (a boxcar: the lowest-latency
  /// linear filter that suppresses the noise it decimates, group delay (k-1)/2 scans); its utime
  /// is the time of the window's centre, the instant the mean refers to.
  double output_rate_hz = 0;
  core::CompensatorSettings compensator;  // scan_rate_hz is taken from the blocks
  core::StatisticsSettings statistics;
};

/// Receives what the pipeline produces (the daemon publishes; tests collect).
class Sink {
 public:
  virtual ~Sink() = default;
  virtual void angle(const pof::angle_t& msg) = 0;
  virtual void cycle(const pof::cycle_stats_t& msg) = 0;
};

class Pipeline {
 public:
  /// Throws std::invalid_argument for settings the compensator rejects.
  Pipeline(io::CalibrationFile cal, std::string cal_path, PipelineSettings s,
           std::optional<core::PotentiometerCalibration> pot_override = std::nullopt);

  /// One raw block. publish_utime stamps the outputs. Never throws.
  void on_block(const pof::raw_block_t& b, std::int64_t publish_utime, Sink& sink) noexcept;

  /// Swaps in a new calibration between blocks (SIGHUP). The velocity history restarts.
  void replace_calibration(io::CalibrationFile cal, std::string cal_path);
  void note_reload_failure(const std::string& why);

  [[nodiscard]] pof::compensator_status_t status(std::int64_t now_utime) const;

 private:
  struct ChannelMap {
    int sensor = -1, reference = -1, angle_ref = -1, pot = -1;
  };
  bool map_channels(const pof::raw_block_t& b) noexcept;
  void ensure_compensator(double scan_rate_hz);
  double reference_angle(const std::vector<float>& scan) const noexcept;
  void emit_angle(std::int64_t publish_utime, Sink& sink);

  io::CalibrationFile cal_;
  std::string cal_path_;
  PipelineSettings s_;
  std::optional<core::PotentiometerCalibration> pot_;
  std::unique_ptr<core::OnlineCompensator> comp_;
  core::CycleStatistics stats_;
  double rate_ = 0;

  ChannelMap ch_;
  std::vector<std::string> mapped_names_;  // names the map was built for (rebuilt when they change)

  // Stream continuity.
  std::optional<std::int64_t> next_seq_, next_scan_;
  std::optional<std::int64_t> t0_utime_;  // time origin for the statistics (double seconds)

  // Decimation window.
  int k_ = 1, in_window_ = 0;
  double sum_angle_ = 0, sum_uncomp_ = 0, sum_ref_ = 0;
  std::int32_t window_quality_ = 0;
  std::int64_t window_first_utime_ = 0;
  pof::angle_t pending_{};

  // Output sequence numbers and counters.
  std::int64_t angle_seq_ = 0, cycle_seq_ = 0;
  pof::compensator_status_t counters_{};
};

}  // namespace pof::compensatord
