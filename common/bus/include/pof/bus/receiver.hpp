#pragma once
// pof::bus::Receiver: the one way pofkit's processes take messages off the LCM bus
// (pof-compensatord, `pof spy`, `pof record`). Total: no datagram, message or handler makes it
// throw, crash or grow without bound; what it cannot use it counts.
//
//   udpm:// (every deployment)  UdpmReceiver: our own socket, bounded reassembly, bound to the
//                               group address (udpm_receiver.hpp), never liblcm's receive thread
//                               (a fragment with offset 0xFFFFFFFF crashes liblcm 1.3.1) unless
//                               ReceiverOptions::udpm_via_liblcm asks for it (`pof record --liblcm`,
//                               kept to measure the difference: BENCHMARKS.md).
//   anything else (memq:// in   subscriptions on the caller's lcm::LCM (memq delivers only within
//   tests)                      one LCM instance, so it must be the one the process publishes on),
//                               or on an lcm::LCM of the receiver's own for a process that only
//                               receives (the second constructor).
//
// A recorder gets what it needs from raw subscriptions: the bytes of every message exactly as they
// arrived (no decoding), the kernel's receive timestamp on udpm:// (liblcm's on the other
// transports), and the malformed-datagram and incomplete-message counters in stats().
//
// Authenticated mode (ReceiverOptions::auth_key, pof/bus/auth.hpp): every message some subscription
// wants is verified before anything else looks at it; what fails (unsigned, bad MAC, stale,
// replayed) is dropped, counted per verdict and reported, and the trailer is taken off what passes,
// so subscribers see the LCM message as it was published. Messages nobody subscribed to are not
// verified (nor counted): a bus shared with other applications costs no MACs.
//
// Both paths hand the raw bytes to one dispatcher: typed subscriptions decode them with the bounded
// decoder (pof/lcm/decode.hpp) into a message object kept per subscription (so the vectors of a
// raw block are reused, not reallocated per message), count what does not decode per channel, and
// call the handler; raw subscriptions (a channel regex with liblcm's semantics, ChannelFilter)
// get the bytes. Exceptions from handlers are caught and counted: nothing crosses the receive loop
// or liblcm's C callback. Errors are also reported, one by one, to an optional error handler (the
// daemons log them rate-limited with ErrorLog).
//
// Threads: one thread subscribes and calls handle(); handlers run on it.
#include <exception>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "pof/bus/auth.hpp"
#include "pof/bus/channel_filter.hpp"
#include "pof/bus/udpm_receiver.hpp"
#include "pof/lcm/decode.hpp"

namespace lcm {
class LCM;
}  // namespace lcm
struct _lcm_recv_buf_t;
struct _lcm_subscription_t;

namespace pof::bus {

/// Where a message came from.
struct Delivery {
  std::string_view channel;
  int64_t recv_utime = 0;  // receive time [us since the Unix epoch] (a kernel timestamp on udpm)
};

/// Per typed channel, since the receiver was created.
struct ChannelStats {
  uint64_t messages = 0;        // messages received on the channel, decodable or not
  uint64_t decode_errors = 0;   // ... that did not decode as the subscribed type
  uint64_t handler_errors = 0;  // handler calls that threw
  uint64_t auth_dropped = 0;    // authenticated mode: messages dropped by the verifier (not in `messages`)
};

struct ReceiverStats {
  // udpm:// only (liblcm counts nothing of the kind): datagrams read, datagrams that are not LCM
  // packets or carry impossible fragment headers, fragmented messages abandoned incomplete.
  uint64_t datagrams = 0;
  uint64_t malformed_datagrams = 0;
  uint64_t incomplete_messages = 0;
  // Summed over the typed channels.
  uint64_t decode_errors = 0;
  uint64_t handler_errors = 0;
  // Authenticated mode: messages dropped per verdict (pof/bus/auth.hpp), over every subscription.
  bool authenticated = false;
  uint64_t auth_unsigned = 0;
  uint64_t auth_bad_mac = 0;
  uint64_t auth_stale = 0;
  uint64_t auth_replayed = 0;
};

/// One message that could not be used, as reported to the error handler.
struct ReceiveError {
  enum class Kind : uint8_t { kDecode, kHandler, kAuth };
  Kind kind = Kind::kDecode;
  std::string_view channel;
  lcmutil::DecodeResult decode;  // kDecode
  bool signed_without_key = false;  // kDecode: the message ends in an authenticated-mode trailer and
                                    // this receiver has no bus key (the usual cause of the error)
  std::string_view what;         // kHandler: the exception's what()
  auth::Verification auth;       // kAuth: why the verifier dropped the message
  /// "POF_RAW: raw_block_t: array 'volts' at byte 90: ..." (bounded, no payload bytes).
  [[nodiscard]] std::string describe() const;
};

struct ReceiverOptions {
  UdpmLimits udpm;
  // Other transports: liblcm's queue per subscription [messages]. Its default, 30, drops the
  // excess silently when the handler thread falls behind.
  int lcm_queue_capacity = 10000;
  // Receive udpm:// through liblcm's subscription too (its receive thread, ring buffer and pipe)
  // instead of UdpmReceiver: slower and not total (see above); only `pof record --liblcm` sets it,
  // to compare the two (BENCHMARKS.md). No malformed/incomplete counts on that path; the
  // authenticated mode verifies there as on memq:// (one verdict per message, see lcm_verdict_).
  bool udpm_via_liblcm = false;
  // Authenticated mode: the bus key (pof/bus/auth_key.hpp loads it) and the verifier's window.
  // Null: unauthenticated, messages are taken as they are.
  std::shared_ptr<const auth::Key> auth_key;
  auth::VerifierSettings auth;
};

class Receiver {
 public:
  using RawHandler = std::function<void(const Delivery&, const unsigned char* data, std::size_t size)>;
  using ErrorHandler = std::function<void(const ReceiveError&)>;

  /// `url` as resolved by pof::bus::resolve_url(). Throws pof::ConfigError naming the URL when the
  /// udpm socket cannot be set up, pof::IoError when `lc` is not good() and is to be used.
  Receiver(lcm::LCM& lc, const std::string& url, ReceiverOptions options = {});
  /// For a process that only receives: an lcm::LCM on `url` is opened (and owned) only when the
  /// transport goes through liblcm; on udpm:// none is (no liblcm socket at all). Throws as above.
  explicit Receiver(const std::string& url, ReceiverOptions options = {});
  ~Receiver();
  Receiver(const Receiver&) = delete;
  Receiver& operator=(const Receiver&) = delete;

  /// fn(const Msg&, const Delivery&) for every message on `channel` (exact name) that decodes as
  /// Msg. Throws std::logic_error if Msg's bounded-decoder layout does not match the generated
  /// type (a build error, caught here at setup rather than as decode errors at run time).
  template <class Msg, class Fn>
  void subscribe(const std::string& channel, Fn fn) {
    add_typed(channel, std::make_unique<Typed<Msg, Fn>>(std::move(fn)), lcmutil::layout_matches<Msg>(),
              lcmutil::Layout<Msg>::kName);
  }

  /// fn(delivery, bytes, size) for every message on a channel matching `regex` (whole name, liblcm's
  /// PCRE syntax). Throws pof::ConfigError naming the pattern when it does not compile.
  void subscribe_raw(const std::string& regex, RawHandler fn);

  /// Called for every decode or handler error (after counting). Must not throw.
  void on_error(ErrorHandler fn) { on_error_ = std::move(fn); }

  /// Waits up to timeout_ms for traffic, then delivers what arrived (a bounded amount, so a flood
  /// cannot hold the caller). Returns the messages taken off the transport (0 on timeout), -1 on a
  /// socket error. Never throws.
  int handle(int timeout_ms) noexcept;

  /// The descriptor to poll() for readability.
  [[nodiscard]] int fd() const;
  /// True when udpm:// is received on our own socket (UdpmReceiver), false through liblcm.
  [[nodiscard]] bool direct() const { return udpm_ != nullptr; }
  [[nodiscard]] ReceiverStats stats() const;
  /// Zeros for a channel nobody subscribed to with a type.
  [[nodiscard]] ChannelStats channel_stats(std::string_view channel) const;

 private:
  struct TypedBase {
    virtual ~TypedBase() = default;
    virtual lcmutil::DecodeResult decode(const unsigned char* data, std::size_t size) noexcept = 0;
    virtual void call(const Delivery& d) = 0;
  };
  template <class Msg, class Fn>
  struct Typed final : TypedBase {
    explicit Typed(Fn f) : fn(std::move(f)) {}
    lcmutil::DecodeResult decode(const unsigned char* data, std::size_t size) noexcept override {
      return lcmutil::decode<Msg>(data, size, msg);
    }
    void call(const Delivery& d) override { fn(static_cast<const Msg&>(msg), d); }
    Msg msg{};
    Fn fn;
  };
  struct Channel {
    std::vector<std::unique_ptr<TypedBase>> subs;
    ChannelStats stats;
  };
  struct Raw {
    std::unique_ptr<ChannelFilter> filter;
    RawHandler fn;
  };
  // What a liblcm subscription's C callback gets: the receiver and whom to deliver to.
  struct Hook {
    Receiver* rx = nullptr;
    Raw* raw = nullptr;  // null: the typed subscriptions of the message's channel
    _lcm_subscription_t* sub = nullptr;
  };

  void add_typed(const std::string& channel, std::unique_ptr<TypedBase> sub, bool layout_ok, std::string_view type);
  void add_lcm_subscription(const std::string& regex, Raw* raw);
  static void on_lcm_message(const _lcm_recv_buf_t* rbuf, const char* channel, void* hook);
  void dispatch(std::string_view channel, const unsigned char* data, std::size_t size, int64_t utime) noexcept;
  /// Authenticated mode: verifies a message, counts and reports a drop; on success `size` becomes
  /// the size of the LCM message in front of the trailer.
  bool authentic(std::string_view channel, const unsigned char* data, std::size_t& size, int64_t utime) noexcept;
  bool raw_matches(Raw& r, std::string_view channel) noexcept;
  void deliver_typed(Channel& c, const Delivery& d, const unsigned char* data, std::size_t size) noexcept;
  void deliver_raw(Raw& r, const Delivery& d, const unsigned char* data, std::size_t size) noexcept;
  void report(const ReceiveError& e) noexcept;
  /// A subscriber's handler threw `error` on `channel`: reported as Kind::kHandler.
  void report_handler_error(std::string_view channel, std::exception_ptr error) noexcept;
  /// Sets up UdpmReceiver for a udpm:// URL (unless udpm_via_liblcm); true when it did.
  bool open_direct(const std::string& url);

  std::unique_ptr<lcm::LCM> own_lc_;  // the second constructor's, when liblcm is used
  lcm::LCM* lc_ = nullptr;            // null only when direct()
  ReceiverOptions opt_;
  std::unique_ptr<UdpmReceiver> udpm_;
  UdpmReceiver::Sink sink_;
  std::map<std::string, Channel, std::less<>> channels_;
  std::vector<std::unique_ptr<Raw>> raw_;
  std::vector<std::unique_ptr<Hook>> hooks_;
  ErrorHandler on_error_;
  std::unique_ptr<auth::Verifier> verifier_;
  // liblcm path: handle() takes one message per lcm_handle() call and liblcm hands it to every
  // matching subscription in turn (lcm/lcm_memq.c, lcm_memq_handle -> lcm_dispatch_handlers; on
  // udpm:// with udpm_via_liblcm lcm/lcm_udpm.c, lcm_udpm_handle, the same per message), so a
  // message is verified once per generation and its verdict reused by the other subscriptions (a
  // second verify() would see its own counter again and call it a replay).
  uint64_t lcm_generation_ = 0;
  struct {
    uint64_t generation = ~uint64_t{0};
    bool ok = false;
    std::size_t size = 0;
  } lcm_verdict_;
};

}  // namespace pof::bus
