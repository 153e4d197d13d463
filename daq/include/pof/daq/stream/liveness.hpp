#pragma once
// Whether the acquisition thread is making progress, as the publisher thread sees it: the systemd
// watchdog is fed, and `streaming` is published, only on that evidence (docs/daq.md, "Watchdog and
// stalls"). A thread that stopped (a blocked device read, a SIGSTOP under a debugger, a deadlock)
// must not be reported as streaming, and the daemon must not keep systemd from restarting it.
//
// Progress is either new scans (Counters::scans) or a heartbeat the state machine advances while it
// opens, waits for, or backs off from a device (it delivers no scans then, but turns). The
// publisher samples both every turn (at most every 50 ms) with its own steady clock: no atomics
// are written here, and nothing is shared.
#include <chrono>
#include <cstdint>

namespace pof::daq {

struct DaqConfig;

/// Consecutive block periods without a scan after which a stream is reported stalled.
inline constexpr int kStallBlocks = 10;
/// Device scans in the largest hand-over a backend makes in normal streaming (a USB-1208LS scan
/// report holds 32 samples; an NI transfer ~4 ms): a stream is never stalled within 10 of these.
inline constexpr int kStallDeviceScans = 32;
/// The floor of the stall bound: host scheduling on a loaded 2-core machine stays well under it.
inline constexpr int kStallFloorMs = 500;

/// How long a stream may deliver no scans before it is reported stalled [ms]: daemon.stall_ms, or
/// with 0 (the default) kStallBlocks x the longer of one published block period and
/// kStallDeviceScans device scans, at least kStallFloorMs.
[[nodiscard]] int stall_bound_ms(const DaqConfig& cfg, double device_rate_hz);

/// How long the acquisition thread may show no progress at all before the watchdog is no longer
/// fed [ms]: the stall bound plus the longest wait a backend legitimately makes without handing
/// over scans (acquisition.data_timeout_ms for data, command_timeout_ms for one command).
[[nodiscard]] int watchdog_grace_ms(const DaqConfig& cfg, int stall_ms);

class Liveness {
 public:
  using Clock = std::chrono::steady_clock;

  Liveness(std::chrono::milliseconds stall, std::chrono::milliseconds grace, Clock::time_point now)
      : stall_(stall), grace_(grace), last_scan_(now), last_progress_(now) {}

  /// One sample of the acquisition thread's counters at `now` (monotonic in calls).
  void observe(Clock::time_point now, std::int64_t scans, std::int64_t heartbeat) {
    if (scans != scans_) {
      scans_ = scans;
      last_scan_ = now;
      last_progress_ = now;
    }
    if (heartbeat != heartbeat_) {
      heartbeat_ = heartbeat;
      last_progress_ = now;
    }
  }
  /// No new scan for longer than the stall bound (meaningful only while a stream is open).
  [[nodiscard]] bool scans_stalled(Clock::time_point now) const { return now - last_scan_ > stall_; }
  /// Time since the last new scan.
  [[nodiscard]] Clock::duration since_scans(Clock::time_point now) const { return now - last_scan_; }
  /// Scans or the heartbeat moved within the grace: the watchdog may be fed.
  [[nodiscard]] bool alive(Clock::time_point now) const { return now - last_progress_ <= grace_; }
  [[nodiscard]] std::int64_t scans() const { return scans_; }
  [[nodiscard]] std::chrono::milliseconds stall() const { return stall_; }

 private:
  std::chrono::milliseconds stall_;
  std::chrono::milliseconds grace_;
  std::int64_t scans_ = 0;
  std::int64_t heartbeat_ = 0;
  Clock::time_point last_scan_;
  Clock::time_point last_progress_;
};

/// True when a block whose newest scan was taken at `newest_scan_utime` leaves the daemon at
/// `publish_utime` more than `stall_ms` later: it was held up (the acquisition thread stalled and
/// then handed over its backlog, or the publisher fell behind), so its samples are old and it is
/// published with raw_block_t.FLAG_LATE. In normal streaming a block leaves within one transfer
/// (a few ms) of its last scan.
[[nodiscard]] inline bool block_is_late(std::int64_t newest_scan_utime, std::int64_t publish_utime, int stall_ms) {
  return publish_utime - newest_scan_utime > std::int64_t{stall_ms} * 1000;
}

}  // namespace pof::daq
