#pragma once
// pof-daqd's lifecycle: the acquisition thread (state machine + the one libusb event loop) and
// the publisher thread (LCM: POF_RAW blocks, POF_DAQ_STATUS at 1 Hz and on every state change).
#include <atomic>
#include <deque>
#include <utility>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "pof/daq/stream/backend.hpp"
#include "pof/daq_status_t.hpp"
#include "pof/daq/stream/acquisition.hpp"
#include "pof/daq/stream/config.hpp"
#include "pof/daq/stream/doorbell.hpp"
#include "pof/daq/stream/liveness.hpp"

namespace lcm {
class LCM;
}  // namespace lcm
namespace pof::bus::auth {
class Key;
}  // namespace pof::bus::auth

namespace pof::daq {

/// Lifecycle (daq_status_t STATE_*). Every wait has a reason and a deadline:
///   kStarting      opening/configuring, then waiting for the first scans; bounded by
///                  command_timeout_ms per command and data_timeout_ms for data
///   kStreaming     scans arrive (set once they do); a transfer silent for data_timeout_ms is an error.
///                  No scan for the stall bound (liveness.hpp) while the session is open: the
///                  publisher reports kFault "acquisition stalled: ..." until scans come again
///                  (then kStreaming, "... resumed after ..."), whatever the backend is doing
///   kDisconnected  device absent; retry every retry_ms, forever (a service never gives up)
///   kFault         device present but failing (or the backend threw, breaking its contract);
///                  retry after retry_ms, doubling per consecutive failure up to 30 s (reset
///                  once a session delivers scans)
///   kStopping      SIGTERM: cancel transfers, stop the scan, release the device
enum class State : std::int8_t { kStarting = 0, kStreaming = 1, kDisconnected = 2, kFault = 3, kStopping = 4 };
const char* state_name(State s);

class Daemon {
 public:
  /// Setup: opens LCM on cfg.lcm_url (as pof::bus::resolve_url() gave it; throws pof::IoError
  /// when the URL does not work), reads the bus key when cfg.auth_key_file names one (throws
  /// pof::ConfigError naming the file: pof/bus/auth_key.hpp) and allocates the queue. `backend` is opened, streamed and closed
  /// again on every attempt.
  Daemon(DaqConfig cfg, std::unique_ptr<Backend> backend);
  /// The same, publishing on the caller's `bus` instead of opening cfg.lcm_url. liblcm's memq://
  /// provider is one queue per lcm::LCM instance, so this is how a process that embeds the daemon
  /// (tests/functional/test_daqd_states.cpp) subscribes to what it publishes. `bus` must outlive
  /// the daemon; the publisher thread publishes on it while the caller's thread may handle() it
  /// (liblcm locks its queue and handler list).
  Daemon(DaqConfig cfg, std::unique_ptr<Backend> backend, lcm::LCM& bus);
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  /// Starts both threads.
  void start();
  /// Asks both threads to stop (async-signal-unsafe: call from a normal thread) and joins them.
  void stop();
  /// True once the acquisition thread has ended by itself: only a finite source does that (a
  /// sim:<scenario> whose trajectory is over); hardware backends stream until stop().
  [[nodiscard]] bool finished() const { return acquisition_done_.load(); }
  /// One line for `pof-daqd --probe`: device, state and its text, scans, protocol variant.
  [[nodiscard]] std::string probe_line();
  /// True once the device has streamed and the protocol variant is fully told (no undecided part).
  [[nodiscard]] bool variant_known() const;
  [[nodiscard]] std::int64_t scans() const { return counters_.scans.load(); }
  /// Raw blocks and statuses LCM refused to publish so far.
  [[nodiscard]] std::int64_t publish_failures() const { return counters_.publish_failures.load(); }
  /// The daq_status_t published for `state` now (seq is the publisher's): counters, identity, rate.
  [[nodiscard]] pof::daq_status_t status(State state, const std::string& text);

 private:
  void acquisition_main();
  void publisher_main();
  void set_state(State s, const std::string& why);
  bool sleep_unless_stopped(int ms);
  /// backend_->open() / stream(), an exception escaping them turned into kFault / kError.
  OpenStatus open_backend(std::string& why);
  StreamEnd stream_backend(ScanSink& sink, std::string& why);
  /// Wait before re-opening after `failures` consecutive failed attempts (back-off).
  [[nodiscard]] int retry_delay_ms(int failures) const;
  /// Publisher thread: `starting` becomes `streaming` once scans of the open session arrive.
  void watch_streaming();
  /// Publisher thread: `streaming` becomes `fault` (stalled) when the open session delivered no
  /// scan for the stall bound, and `streaming` again once scans move.
  void watch_stall(const Liveness& live, Liveness::Clock::time_point now);
  /// Acquisition thread: the state machine turned (it opens, waits or backs off: no scans then).
  void beat() { heartbeat_.fetch_add(1, std::memory_order_relaxed); }

  DaqConfig cfg_;
  std::unique_ptr<Backend> backend_;
  std::unique_ptr<lcm::LCM> owned_lcm_;  // opened from cfg.lcm_url, unless the caller gave a bus
  lcm::LCM* lcm_;
  std::shared_ptr<const bus::auth::Key> key_;  // authenticated mode; null: unauthenticated
  SpscQueue<Block> queue_;
  Counters counters_;
  Doorbell wake_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> publisher_stop_{false};
  std::atomic<bool> acquisition_done_{false};
  // The published rate: the device's real scan rate (its clock divisor rounds the configured one)
  // over the decimation; set by the acquisition thread at the first open.
  std::atomic<double> published_rate_hz_{0.0};
  // counters_.scans when the current session was opened; -1 between sessions.
  std::atomic<std::int64_t> armed_scans_{-1};
  // Advanced by the acquisition thread at every turn of its state machine (not while a backend
  // streams: scans are the proof then). The publisher feeds the watchdog only when this or the
  // scan count moved within the grace (liveness.hpp).
  std::atomic<std::int64_t> heartbeat_{0};
  // State changes, queued so that the publisher sends one status per change even when several
  // happen between two of its wake-ups (control path: allocation is fine here).
  std::mutex state_mu_;
  State state_ = State::kStarting;
  std::string state_text_ = "starting";
  std::deque<std::pair<State, std::string>> state_events_;
  // The publisher set kFault because the open session stalled (guarded by state_mu_); any state
  // the acquisition thread sets clears it.
  bool stalled_ = false;
  std::int64_t stalled_scans_ = 0;  // counters_.scans when the stall was reported
  DeviceIdentity identity_;  // of the device opened last (guarded by state_mu_)
  std::thread acq_thread_;
  std::thread pub_thread_;
};

}  // namespace pof::daq
