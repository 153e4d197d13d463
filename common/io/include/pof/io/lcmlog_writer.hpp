#pragma once
// LCM log recordings: pof::raw_block_t messages on POF_RAW (lcmtypes/raw_block_t.lcm), blocks of
// `block_scans` scans with channels "sensor", "reference", "pot" [V], "angle_ref" [deg] and
// optionally "angle_true" [deg] (the recording contract every reader accepts, README "Conventions"). Times are a fixed epoch plus the
// scan time, so the file is byte-for-byte deterministic; the log event timestamp is the block's
// publish_utime (the time of its last scan). Readable by lcm-logplayer. Written atomically.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "pof/bus/channels.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/io/recording.hpp"
#include "pof/io/recording_row.hpp"

namespace pof::io {

/// 2017-10-01T00:00:00Z in us since the Unix epoch (the paper's publication month).
inline constexpr std::int64_t kDefaultEpochUtime = 1506816000LL * 1000000LL;

struct LcmLogOptions {
  std::string channel = bus::channel(bus::Stream::kRaw);
  std::string sensor_id;               // raw_block_t.sensor_id
  double scan_rate_hz = 200;           // raw_block_t.scan_rate_hz
  int block_scans = 20;                // scans per message (100 ms at 200 Hz)
  std::int64_t epoch_utime = kDefaultEpochUtime;  // utime of t_s = 0
  bool simulated = true;               // FLAG_SIMULATED on every block
  bool pot = true;                     // write the "pot" channel
  bool angle_ref = true;               // write the "angle_ref" channel
  bool angle_true = true;              // write the "angle_true" channel (simulator only)
};

class LcmLogWriter {
 public:
  /// Throws IoError (cannot create the file) or std::invalid_argument (block_scans < 1).
  LcmLogWriter(const std::filesystem::path& path, LcmLogOptions options);
  LcmLogWriter(const LcmLogWriter&) = delete;
  LcmLogWriter& operator=(const LcmLogWriter&) = delete;
  /// Discards the output unless commit() was called.
  ~LcmLogWriter();

  /// Appends a scan; a full block is encoded and written. Throws IoError on a write error.
  void write(const RecordingRow& row);
  /// Writes the last (partial) block, closes and renames onto the destination. Throws IoError.
  void commit();
  [[nodiscard]] std::int64_t blocks() const { return seq_; }

 private:
  struct Impl;
  void flush_block();
  AtomicFile file_;
  LcmLogOptions opt_;
  std::unique_ptr<Impl> impl_;
  std::int64_t seq_ = 0;
  std::int64_t scans_ = 0;
};

/// The whole recording (rows with angle_ref_deg/pot_v/angle_true_deg as present).
void write_lcmlog(const std::filesystem::path& path, const Recording& rec, LcmLogOptions options);

}  // namespace pof::io
