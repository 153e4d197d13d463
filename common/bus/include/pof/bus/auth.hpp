#pragma once
// Authenticated mode of the LCM bus (docs/deployment.md, "Authenticated mode"): with a bus key,
// every message a pofkit process publishes carries the trailer of pof/bus/auth_trailer.hpp (a MAC
// and a counter), and every pofkit receiver verifies it before it decodes anything. Off by default:
// without a key nothing is appended and nothing is checked.
//
// Pure: no sockets, no clock, no files. The caller passes the time (realtime microseconds, the LCM
// utime convention); keys are read by pof/bus/auth_key.hpp. libsodium does the cryptography:
// keyed BLAKE2b (crypto_generichash), the constant-time comparison (sodium_memcmp) and the
// random sender id (randombytes_buf).
//
// Why keyed BLAKE2b-256 and not HMAC-SHA-512-256 (libsodium's crypto_auth): both are MACs with a
// 256-bit key; BLAKE2b's keyed mode is a MAC by construction (RFC 7693, abstract: "BLAKE2 can be
// directly keyed, making it functionally equivalent to a Message Authentication Code"), takes one
// pass instead of HMAC's two, and is in Python's standard library (hashlib.blake2b with
// key=), so a Python controller or test can sign and verify without libsodium.
//
// What a receiver accepts, in this order (the first failed check is the verdict):
//   kUnsigned  no trailer of this version at the end of the message;
//   kBadMac    the key id is not ours (signed with another key) or the MAC does not match: a forged
//              or altered message;
//   kStale     the counter (the sender's clock) is more than `window` away from the receiver's
//              clock, either way: a replay of an old session, or clocks not synchronised;
//   kReplayed  within the window, but not beyond the last counter accepted from that sender on that
//              channel: a message seen before.
// Whatever is not kOk is dropped by the caller and counted here per verdict.
//
// Limits (docs/deployment.md, "Threat model"): whoever has the key can sign anything; the messages
// are not encrypted; the counter is the sender's clock, so sender and receivers need synchronised
// clocks (chrony, PTP) to within a fraction of the window; a receiver that restarts has forgotten
// the counters it accepted and takes, once, messages of the last window it never saw.
//
// Threads: a Key is immutable and may be shared. A Signer or a Verifier is used by one thread.
#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <utility>

#include "pof/bus/auth_trailer.hpp"

namespace pof::bus::auth {

/// A bus key: 32 secret bytes, wiped from memory when destroyed.
class Key {
 public:
  static constexpr std::size_t kBytes = 32;
  /// Throws std::invalid_argument unless n == kBytes; std::runtime_error if libsodium cannot start.
  Key(const unsigned char* bytes, std::size_t n);
  ~Key();
  Key(const Key&) = delete;
  Key& operator=(const Key&) = delete;

  /// The key id of the trailer (auth_trailer.hpp): not secret, names the key in messages.
  [[nodiscard]] std::uint32_t id() const { return id_; }
  [[nodiscard]] const unsigned char* bytes() const { return bytes_.data(); }

 private:
  std::array<unsigned char, kBytes> bytes_{};
  std::uint32_t id_ = 0;
};

/// "1a2b3c4d": a key id as messages and manifests write it.
std::string key_id_hex(std::uint32_t id);

/// The MAC of the trailer (auth_trailer.hpp) over `channel`, the `size` message bytes and the
/// trailer's 28 header bytes.
void compute_mac(const Key& key, std::string_view channel, const unsigned char* message, std::size_t size,
                 const unsigned char* trailer_header, unsigned char* mac_out);

/// A sender id for a process start: 64 random bits (randombytes_buf).
std::uint64_t random_sender_id();

/// Realtime microseconds as a counter: negative times (a clock before 1970) are 0.
constexpr std::uint64_t counter_time(std::int64_t utime) { return utime < 0 ? 0 : static_cast<std::uint64_t>(utime); }

class Signer {
 public:
  Signer(std::shared_ptr<const Key> key, std::uint64_t sender_id);

  /// Writes the trailer for a message of `size` bytes at `buf` on `channel`, right after it: `buf`
  /// must have room for size + kTrailerBytes. The counter is now_us, or the previous one + 1 when
  /// the clock has not advanced past it (it never goes back, not even when the clock does).
  /// Returns false and writes nothing once the counter is saturated at UINT64_MAX: it never wraps
  /// (a wrapped counter would be taken for an old message, or a replay for a new one).
  bool sign(std::string_view channel, unsigned char* buf, std::size_t size, std::uint64_t now_us) noexcept;

  [[nodiscard]] std::uint64_t sender_id() const { return sender_; }
  [[nodiscard]] std::uint64_t last_counter() const { return last_; }
  [[nodiscard]] std::uint32_t key_id() const { return key_->id(); }

 private:
  std::shared_ptr<const Key> key_;
  std::uint64_t sender_;
  std::uint64_t last_ = 0;
  bool signed_any_ = false;
};

enum class Verdict : std::uint8_t { kOk, kUnsigned, kBadMac, kStale, kReplayed };
inline constexpr Verdict kDropVerdicts[] = {Verdict::kUnsigned, Verdict::kBadMac, Verdict::kStale, Verdict::kReplayed};

/// "ok", "unsigned", "bad_mac", "stale", "replayed": the names status fields and manifests use.
const char* verdict_name(Verdict v);

struct VerifierSettings {
  /// Largest difference between a message's counter and the receiver's clock [us], either way.
  std::uint64_t window_us = 2'000'000;
  /// (sender, channel) pairs whose last counter is remembered. Only messages with a valid MAC
  /// create one; beyond the bound, pairs not heard from within the window are forgotten first
  /// (their old messages are stale anyway), then the one heard from least recently.
  std::size_t max_streams = 1024;
};

/// What verify() found about one message.
struct Verification {
  Verdict verdict = Verdict::kUnsigned;
  std::size_t message_size = 0;  // kOk: the LCM message in front of the trailer
  std::uint64_t sender = 0;      // from the trailer (not authentic unless kOk)
  std::uint64_t counter = 0;
  std::uint64_t last_counter = 0;  // kReplayed: the last one accepted from the sender on the channel
  std::uint32_t key_id = 0;
  std::uint32_t our_key_id = 0;
  std::uint64_t now_us = 0;
  std::uint64_t window_us = 0;
  [[nodiscard]] bool ok() const { return verdict == Verdict::kOk; }
  /// "not authenticated: no pofkit trailer ...", "bad MAC from sender 0x...: signed with another key
  /// (key id ..., ours ...)", "stale: counter 3.200 s behind this host's clock ...". Bounded.
  [[nodiscard]] std::string describe() const;
};

class Verifier {
 public:
  explicit Verifier(std::shared_ptr<const Key> key, VerifierSettings settings = {});

  /// Checks `size` bytes received on `channel` at now_us (the receiver's realtime clock, e.g. the
  /// kernel's receive timestamp). Never throws; counts the verdict.
  Verification verify(std::string_view channel, const unsigned char* data, std::size_t size,
                      std::uint64_t now_us) noexcept;

  /// Messages with this verdict since construction.
  [[nodiscard]] std::uint64_t count(Verdict v) const { return counts_[static_cast<std::size_t>(v)]; }
  [[nodiscard]] std::size_t streams() const { return last_.size(); }
  [[nodiscard]] std::uint32_t key_id() const { return key_->id(); }
  [[nodiscard]] const VerifierSettings& settings() const { return s_; }

 private:
  using StreamKey = std::pair<std::uint64_t, std::string>;  // (sender, channel)
  struct StreamLess {
    using is_transparent = void;
    template <class A, class B>
    bool operator()(const A& a, const B& b) const {
      return a.first != b.first ? a.first < b.first : std::string_view(a.second) < std::string_view(b.second);
    }
  };
  void make_room(std::uint64_t now_us);

  std::shared_ptr<const Key> key_;
  VerifierSettings s_;
  std::map<StreamKey, std::uint64_t, StreamLess> last_;
  std::array<std::uint64_t, 5> counts_{};
};

}  // namespace pof::bus::auth
