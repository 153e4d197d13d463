#pragma once
// The streaming path between a backend and the LCM publisher: scan indices, timestamps
// (ScanClock), decimation, block assembly and the SPSC hand-off. Runs on the acquisition thread;
// allocates nothing after construction and never logs: problems become counters (the habit of PX4 drivers).
#include <atomic>
#include <cstdint>

#include "pof/daq/stream/backend.hpp"
#include "pof/daq/stream/config.hpp"
#include "pof/daq/stream/doorbell.hpp"
#include "pof/daq/stream/scan_clock.hpp"
#include "pof/daq/stream/spsc_queue.hpp"

namespace pof::daq {

/// Counters published in daq_status_t. Written by the acquisition thread (and the publisher for
/// `blocks` and `publish_failures`), read by the publisher. They never go backwards.
struct Counters {
  std::atomic<std::int64_t> scans{0};          // device scans received
  std::atomic<std::int64_t> blocks{0};         // raw blocks published
  std::atomic<std::int64_t> dropped_scans{0};  // published scans missing from the index sequence
  std::atomic<std::int64_t> usb_errors{0};
  std::atomic<std::int64_t> overruns{0};       // blocks dropped because the queue was full
  std::atomic<std::int64_t> reconnects{0};
  std::atomic<std::int64_t> padding_set{0};    // samples with padding bits set (kept)
  std::atomic<std::int64_t> publish_failures{0};  // raw blocks and statuses LCM refused
  std::atomic<std::uint32_t> variant{0};       // Variant bits of the current session
};

/// One raw block in the queue (fixed size: no allocation when handed over).
struct Block {
  std::int64_t utime = 0;       // host time of the first scan [us]
  std::int64_t first_scan = 0;  // published scan index of the first scan
  std::int32_t n_scans = 0;
  std::int32_t flags = 0;
  float volts[kMaxBlockScans * kMaxChannels];  // scan-major
};

class Acquisition final : public ScanSink {
 public:
  /// `device_rate_hz`: the rate the device really runs at. `wake` is rung once per block.
  Acquisition(const DaqConfig& cfg, double device_rate_hz, SpscQueue<Block>& queue,
              Counters& counters, Doorbell& wake);

  void on_segment_start(std::int64_t earliest_us, std::int64_t latest_us,
                        bool continuous) noexcept override;
  void on_scans(const float* volts, std::size_t n_scans, std::int64_t arrival_us,
                std::int32_t flags) noexcept override;
  void on_usb_error() noexcept override;
  void on_variant(std::uint32_t bits) noexcept override;
  void on_padding_set(std::size_t n) noexcept override;

  [[nodiscard]] double published_rate_hz() const { return device_rate_hz_ / decimate_; }
  [[nodiscard]] const ScanClock& clock() const { return clock_; }

 private:
  void emit_output_scan(std::int32_t flags) noexcept;
  void flush_block() noexcept;

  std::size_t n_ch_;
  double device_rate_hz_;
  int decimate_;
  int block_scans_;
  SpscQueue<Block>& queue_;
  Counters& counters_;
  Doorbell& wake_;
  ScanClock clock_;

  bool started_ = false;
  std::int64_t device_index_ = 0;  // index of the next device scan
  // decimation window
  double sum_[kMaxChannels] = {};
  int in_window_ = 0;
  std::int32_t window_flags_ = 0;
  // block under construction
  Block* block_ = nullptr;
  std::int32_t pending_flags_ = 0;  // FLAG_GAP etc. for the next block
  std::int64_t last_utime_ = 0;     // of the last block begun: utime never steps back
};

}  // namespace pof::daq
