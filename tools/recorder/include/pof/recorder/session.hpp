#pragma once
// A lossless LCM recording session (`pof record`).
//
// Why not lcm-logger: it keeps LCM's default 30-message subscription queue and writes to disk in
// the thread that calls handle(), so at 20k-100k msg/s it drops messages silently
// (docs/lcm.md). Here:
//   - the UDP receive buffer is enlarged through the URL (recv_buf_size) and what the kernel really
//     granted is checked (net.core.rmem_max caps it; deploy/sysctl.d/60-pof-lcm.conf raises that);
//   - the subscription queue capacity is raised (setQueueCapacity);
//   - the LCM thread only copies each message into a bounded hand-off queue (bounded in bytes);
//     a writer thread owns all disk I/O (DurableLogWriter: whole events, periodic fdatasync);
//   - every loss is counted: hand-off overflow, kernel socket drops (/proc/net/udp), and sequence
//     gaps of pofkit's own streams.
// In the authenticated mode (SessionOptions::auth_key, pof/bus/auth.hpp) the session's
// bus::Receiver verifies every message before it reaches the hand-off queue (ReceiverOptions::
// auth_key, on every receive path, --liblcm included): what fails (unsigned, bad MAC, stale,
// replayed) is not recorded and is counted per verdict in the manifest (the Receiver's counters,
// ReceiverStats::auth_*); what passes is recorded without its trailer, as the LCM message that was
// published, so every LCM log reader (lcm-logplayer, pofkit's own) takes the log as it takes any
// other. The manifest says that the session was verified and with which key id.
//
// Threads: the constructor, start(), poll() and stop() are called from one controlling thread; the
// session runs an LCM thread and a writer thread of its own. Setup errors throw pof::io errors
// (ConfigError for a bad URL/regex, IoError for an unwritable output, NoInputError for a missing
// --manifest-file); failures while recording are reported by poll().outcome, never thrown.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string_view>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "pof/bus/auth.hpp"
#include "pof/bus/fingerprint.hpp"
#include "pof/recorder/channel_cap.hpp"
#include "pof/recorder/lcmlog_durable.hpp"
#include "pof/recorder/pof_messages.hpp"

namespace pof::bus {
class Receiver;
}  // namespace pof::bus

namespace pof::recorder {

struct SessionOptions {
  std::string lcm_url;                 // "": $LCM_DEFAULT_URL, else udpm on this host (pof/bus/url.hpp)
  // Added to a udpm:// URL that has no recv_buf_size: 16 MiB holds ~1/4 s of 100k msg/s of
  // 300-byte messages (kernel accounting ~1 KB per datagram), enough to ride out scheduling stalls
  // on a loaded 2-core host.
  int recv_buf_bytes = 16 << 20;
  std::string channels = ".*";         // LCM channel regex (whole-name match, as lcm-logger -c)
  std::filesystem::path output;        // log file, or a directory (a timestamped name is chosen in it)
  uint64_t rotate_bytes = 0;           // start a new file when the next event would exceed this (0: never)
  double rotate_seconds = 0;           // start a new file after this long (0: never)
  double sync_interval_s = 0.5;        // fdatasync period: the most a power loss can take
  int lcm_queue_capacity = 1 << 20;    // per-subscription queue [messages] (LCM default: 30)
  std::size_t handoff_bytes = 256u << 20;  // bound of the LCM->writer queue [bytes]
  std::vector<std::filesystem::path> manifest_files;  // copied next to the log and listed
  // Messages come off the bus through pof::bus::Receiver, pofkit's one receive path (a raw
  // subscription: bytes and receive time of every message, nothing decoded). On udpm:// that is
  // UdpmReceiver (recvmmsg batches; udpm_receiver.hpp says why) unless use_liblcm is set; other
  // providers (memq://, file://) always go through liblcm.
  bool use_liblcm = false;
  int receive_nice = -10;              // nice value of the receive thread (0: leave it)
  std::shared_ptr<const bus::auth::Key> auth_key;  // authenticated mode; null: record what arrives
  bus::auth::VerifierSettings auth;                // its freshness window
  nlohmann::json manifest_extra = nlohmann::json::object();  // versions, command line, config
};

// kDiskFull / kIoError: writing stopped, the log is complete up to the failure. kFailed: not even
// the first event could be written (a full disk at start, a file size limit): nothing recorded, and
// the empty log file removed (a 0-byte log would pass for a recording of a silent bus).
enum class Outcome { kRunning, kStopped, kDiskFull, kIoError, kFailed };

struct ChannelStats {
  uint64_t events = 0;
  uint64_t bytes = 0;
  bus::MessageType type = bus::MessageType::kUnknown;
  uint64_t fingerprint = 0;
  SeqTracker seq;
};

struct SessionStats {
  Outcome outcome = Outcome::kRunning;
  std::string error;                // one line naming the file and the errno text, when failed
  uint64_t received = 0;            // messages the LCM thread saw (authenticated mode: that passed verification)
  uint64_t written = 0;             // events in the log files (written through write(2))
  uint64_t dropped_handoff = 0;     // hand-off queue full (writer too slow)
  // Received but never written because writing stopped (disk full, I/O error; `error` says why):
  // the events a failed write cut back, the rest of the writer's batch, everything received after.
  // Once stopped: received == written + dropped_handoff + not_written.
  uint64_t not_written = 0;
  uint64_t udp_drops = 0;           // kernel drops on our LCM socket since start
  uint64_t malformed_datagrams = 0; // datagrams that are not LCM packets or carry impossible fragment headers
  uint64_t incomplete_messages = 0; // fragmented messages abandoned before their last fragment
  bool authenticated = false;       // authenticated mode: messages not recorded, per verdict
  uint64_t auth_unsigned = 0, auth_bad_mac = 0, auth_stale = 0, auth_replayed = 0;
  int udp_rcvbuf_bytes = 0;         // receive buffer the kernel granted (0: not udpm)
  std::size_t handoff_peak_bytes = 0;
  std::vector<std::filesystem::path> files;
  std::filesystem::path manifest;
};

class Session {
 public:
  explicit Session(SessionOptions options);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  /// Subscribes and starts both threads; the first file and the manifest exist when it returns.
  void start();
  /// A snapshot of the counters (cheap; call it at a few Hz).
  SessionStats poll();
  /// Stops receiving, drains the hand-off queue into the log, syncs, closes and writes the final
  /// manifest. Idempotent. Returns the final counters.
  SessionStats stop();
  /// Monotonic heartbeat of the writer thread; the watchdog is fed only while it moves.
  [[nodiscard]] uint64_t writer_heartbeat() const { return writer_beats_.load(); }
  [[nodiscard]] uint64_t lcm_heartbeat() const { return lcm_beats_.load(); }

  /// "recvmmsg" or "liblcm": how messages are received.
  [[nodiscard]] const char* receiver_name() const { return direct_ ? "recvmmsg" : "liblcm"; }
  /// The URL actually used (recv_buf_size added).
  [[nodiscard]] const std::string& url() const { return url_; }

 private:
  // Hand-off records, packed back to back in one arena (no allocation per message at 100k msg/s):
  // i64 utime, u32 channel length, u32 data length (host order), channel bytes, data bytes.
  static constexpr std::size_t kRecordHeader = 16;

  void enqueue(int64_t utime, std::string_view channel, const void* data, uint32_t size);
  void lcm_loop();
  void writer_loop();
  bool open_next_file();
  std::string manifest_text(const char* status);
  void write_manifest(const char* status);
  void write_manifest_noexcept(const char* status) noexcept;
  /// The manifest at stop, rewritten in place when write-then-rename fails (see session.cpp).
  void write_final_manifest(const char* status) noexcept;
  /// A writer failure, under stats_mu_: sets outcome_ and error_; a file with no complete event is
  /// closed and removed.
  void note_write_failure();
  void note_event(int64_t utime, std::string_view channel, const unsigned char* data, uint32_t size);
  [[nodiscard]] uint64_t not_written_locked() const;
  std::string error_reason();
  bool rotate();
  std::filesystem::path file_path(unsigned index) const;

  SessionOptions opt_;
  std::string url_;
  std::filesystem::path base_;  // the output path, with a directory resolved to a file name
  std::filesystem::path manifest_path_;
  std::filesystem::path attach_dir_;
  nlohmann::json recorder_;  // this process, for the manifest (pof/recorder/manifest_state.hpp)
  nlohmann::json attachments_ = nlohmann::json::array();
  std::unique_ptr<bus::Receiver> rx_;  // receive thread only, once started
  bool direct_ = false;                // rx_->direct(), kept for the manifest after rx_ is gone
  uint16_t port_ = 0;
  uint64_t udp_drops_at_start_ = 0;
  int64_t start_utime_ = 0;
  int64_t stop_utime_ = 0;

  // Hand-off (LCM thread -> writer thread).
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<unsigned char> pending_;
  uint64_t pending_events_ = 0;
  std::size_t pending_bytes_ = 0;
  std::size_t peak_bytes_ = 0;
  uint64_t received_ = 0;
  uint64_t dropped_ = 0;
  uint64_t refused_ = 0;  // received after writing stopped
  bool accepting_ = true;

  std::atomic<bool> stop_lcm_{false};
  std::atomic<bool> stop_writer_{false};
  std::atomic<uint64_t> writer_beats_{0};
  std::atomic<uint64_t> lcm_beats_{0};
  // The receiver's udpm counters, published by the receive thread after each handle().
  std::atomic<uint64_t> malformed_{0}, incomplete_{0};
  // Authenticated mode: the receiver's drops per verdict, published with the counters above.
  std::atomic<uint64_t> auth_unsigned_{0}, auth_bad_mac_{0}, auth_stale_{0}, auth_replayed_{0};
  std::thread lcm_thread_;
  std::thread writer_thread_;
  bool started_ = false;
  bool stopped_ = false;

  // Writer-thread state (read by poll() under stats_mu_).
  std::mutex stats_mu_;
  std::unique_ptr<DurableLogWriter> writer_;
  unsigned file_index_ = 0;
  uint64_t file_bytes_ = 0;
  std::chrono::steady_clock::time_point file_opened_{};
  struct FileInfo {
    std::filesystem::path path;
    uint64_t events = 0;
    uint64_t bytes = 0;
    int64_t first_utime = 0;
    int64_t last_utime = 0;
  };
  std::vector<FileInfo> files_;
  // At most kMaxTrackedChannels (+ kPofChannelReserve POF_*) names; the rest in other_.
  std::map<std::string, ChannelStats, std::less<>> channels_;
  OtherChannels other_;
  uint64_t written_ = 0;
  uint64_t taken_ = 0;           // events the writer took from the hand-off
  bool writer_failed_ = false;   // the writer stopped writing (outcome_ says why)
  Outcome outcome_ = Outcome::kRunning;
  std::string error_;
  uint64_t final_udp_drops_ = 0;
  int final_rcvbuf_ = 0;
};

const char* outcome_name(Outcome o);

}  // namespace pof::recorder
