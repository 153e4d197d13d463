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
#include <array>
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
  /// Take a calibration made for another sensor (its sensor_id differs from this one). Off: such
  /// a file is refused at start and on reload, so swapped knees never give wrong angles of good
  /// quality.
  bool allow_other_sensor = false;
  /// Published angle rate [Hz]; 0 publishes every scan. Otherwise every k = round(scan rate /
  /// output rate) scans one angle_t carries the mean of those k scans (a boxcar: the lowest-latency
  /// linear filter that suppresses the noise it decimates, group delay (k-1)/2 scans); its utime
  /// is the time of the window's centre, the instant the mean refers to.
  double output_rate_hz = 0;
  core::CompensatorSettings compensator;  // scan_rate_hz is taken from the blocks
  core::StatisticsSettings statistics;
};

/// Receives what the pipeline produces (the daemon publishes; tests collect). Each returns false
/// when the message could not be published (LCM refused it): the pipeline counts it in
/// compensator_status_t.publish_failures. Must not throw.
class Sink {
 public:
  virtual ~Sink() = default;
  virtual bool angle(const pof::angle_t& msg) = 0;
  virtual bool cycle(const pof::cycle_stats_t& msg) = 0;
};

/// The status's last_error when blocks carry potentiometer volts and nothing calibrates them.
inline constexpr const char* kNoPotentiometer =
    "blocks carry 'pot' volts but there is no potentiometer calibration: the reference angle is NaN and no "
    "cycle statistics (POF_STATS) are published; give --pot-cal FILE, or calibrate with `pof calibrate "
    "--pot-cal FILE` so cal.toml carries it (docs/calibration.md, \"Potentiometer\")";

class Pipeline {
 public:
  /// Throws std::invalid_argument for settings the compensator rejects.
  Pipeline(io::CalibrationFile cal, std::string cal_path, PipelineSettings s,
           std::optional<core::PotentiometerCalibration> pot_override = std::nullopt);

  /// One raw block. publish_utime stamps the outputs. Never throws.
  ///
  /// Blocks of one publisher (pof-daqd) advance: seq by 1 per block, first_scan by the scans of
  /// the previous block or more (scans lost at the device). A block that does not advance both is
  /// a duplicate or a replay and is dropped (duplicate_blocks), unless it is a restart of the
  /// publisher: seq 0 with a utime after the last block taken (a new pof-daqd numbers from 0 and
  /// stamps with the host clock; a replayed first block carries its old time). After
  /// kResyncBlocks consecutive dropped blocks the stream is taken as a new one, so neither a forged
  /// block far ahead nor a clock stepped back at a restart can silence the daemon for good.
  /// Counters saturate at INT64_MAX instead of wrapping on forged numbers.
  void on_block(const pof::raw_block_t& b, std::int64_t publish_utime, Sink& sink) noexcept;

  /// Closes the cycle in progress and publishes its statistics if it is complete: the stream went
  /// quiet (pof-daqd stopped, the cable is out) or the daemon is stopping. Without this the last
  /// cycle of a session would never be published (a cycle otherwise closes at the next flexion or
  /// after a hold, StatisticsSettings::close_after_hold_s). Never throws.
  void finish(Sink& sink) noexcept;

  static constexpr int kResyncBlocks = 16;

  /// Swaps in a new calibration between blocks (SIGHUP). The velocity history restarts.
  void replace_calibration(io::CalibrationFile cal, std::string cal_path);
  void note_reload_failure(const std::string& why);
  /// A message the daemon failed to publish outside the pipeline (its status), counted with the
  /// angles and cycles the Sink refused in publish_failures.
  void note_publish_failure() noexcept;

  [[nodiscard]] pof::compensator_status_t status(std::int64_t now_utime) const;

 private:
  struct ChannelMap {
    int sensor = -1, reference = -1, angle_ref = -1, pot = -1;
  };
  bool map_channels(const pof::raw_block_t& b) noexcept;
  void ensure_compensator(double scan_rate_hz);
  double reference_angle(const std::vector<float>& scan) const noexcept;
  void emit_angle(std::int64_t publish_utime, Sink& sink);
  void emit_cycle(Sink& sink);

  io::CalibrationFile cal_;
  std::string cal_path_;
  PipelineSettings s_;
  std::optional<core::PotentiometerCalibration> pot_;
  std::unique_ptr<core::OnlineCompensator> comp_;
  core::CycleStatistics stats_;
  double rate_ = 0;

  ChannelMap ch_;
  std::vector<std::string> mapped_names_;  // names the map was built for (rebuilt when they change)

  // Stream continuity: the last block taken, the scan index expected next, and how many blocks in
  // a row were dropped as duplicates or replays.
  std::optional<std::int64_t> last_seq_, next_scan_;
  std::int64_t last_utime_ = 0;
  int stale_run_ = 0;
  std::optional<std::int64_t> t0_utime_;  // time origin for the statistics (double seconds)

  // Decimation window.
  int k_ = 1, in_window_ = 0;
  double sum_angle_ = 0, sum_uncomp_ = 0, sum_ref_ = 0, sum_sigma_ = 0;
  std::int32_t window_quality_ = 0;
  std::int64_t window_first_utime_ = 0;
  pof::angle_t pending_{};

  // Output sequence numbers and counters.
  std::int64_t angle_seq_ = 0, cycle_seq_ = 0;
  pof::compensator_status_t counters_{};
  // The estimator's divergences counted by compensators since replaced (a reload, a new rate), so
  // that the status's count never goes backwards.
  std::int64_t divergences_retired_ = 0;
  void retire_compensator() noexcept;
  // The reference angle of the scan `lag` back (NaN until there is one), for the estimator's
  // fixed lag: a ring of the last lag + 1.
  std::array<double, core::kMaxSmootherLag + 1> refs_{};
  int refs_head_ = 0, refs_stored_ = 0;
  double delayed_reference(double ref, int lag) noexcept;
};

}  // namespace pof::compensatord
