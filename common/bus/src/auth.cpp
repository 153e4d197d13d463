// The authenticated mode's MAC, signer and verifier; the why is in pof/bus/auth.hpp.
#include "pof/bus/auth.hpp"

#include <sodium.h>

#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace pof::bus::auth {
namespace {

constexpr char kKeyIdContext[] = "pofkit-lcm-key-id";

void init_sodium() {
  if (sodium_init() < 0) throw std::runtime_error("libsodium could not be initialised (sodium_init)");
}

void put_be(unsigned char* p, std::uint64_t v, int n) { detail::put_be(p, v, n); }

std::string hex64(std::uint64_t v) {
  char b[24];
  std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(v));
  return b;
}

std::string seconds(std::uint64_t us) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f s", static_cast<double>(us) / 1e6);
  return b;
}

}  // namespace

Key::Key(const unsigned char* bytes, std::size_t n) {
  if (bytes == nullptr || n != kBytes)
    throw std::invalid_argument("a bus key is " + std::to_string(kBytes) + " bytes, not " + std::to_string(n));
  init_sodium();
  std::memcpy(bytes_.data(), bytes, kBytes);
  unsigned char h[crypto_generichash_BYTES_MIN];  // 16: BLAKE2b's shortest libsodium output
  crypto_generichash(h, sizeof h, reinterpret_cast<const unsigned char*>(kKeyIdContext), sizeof kKeyIdContext - 1,
                     bytes_.data(), bytes_.size());
  id_ = static_cast<std::uint32_t>(detail::get_be(h, 4));
}

Key::~Key() { sodium_memzero(bytes_.data(), bytes_.size()); }

std::string key_id_hex(std::uint32_t id) {
  char b[12];
  std::snprintf(b, sizeof b, "%08x", static_cast<unsigned>(id));
  return b;
}

void compute_mac(const Key& key, std::string_view channel, const unsigned char* message, std::size_t size,
                 const unsigned char* trailer_header, unsigned char* mac_out) {
  static_assert(kMacBytes >= crypto_generichash_BYTES_MIN && kMacBytes <= crypto_generichash_BYTES_MAX);
  crypto_generichash_state st;
  crypto_generichash_init(&st, key.bytes(), Key::kBytes, kMacBytes);
  // Lengths first: the channel and the message cannot trade bytes with each other.
  unsigned char len[8];
  put_be(len, channel.size(), 4);
  crypto_generichash_update(&st, len, 4);
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(channel.data()), channel.size());
  put_be(len, size, 8);
  crypto_generichash_update(&st, len, 8);
  if (size > 0) crypto_generichash_update(&st, message, size);
  crypto_generichash_update(&st, trailer_header, kTrailerHeaderBytes);
  crypto_generichash_final(&st, mac_out, kMacBytes);
  sodium_memzero(&st, sizeof st);
}

std::uint64_t random_sender_id() {
  init_sodium();
  std::uint64_t v = 0;
  randombytes_buf(&v, sizeof v);
  return v;
}

Signer::Signer(std::shared_ptr<const Key> key, std::uint64_t sender_id) : key_(std::move(key)), sender_(sender_id) {
  if (!key_) throw std::invalid_argument("Signer: no key");
}

bool Signer::sign(std::string_view channel, unsigned char* buf, std::size_t size, std::uint64_t now_us) noexcept {
  std::uint64_t counter = now_us;
  if (signed_any_ && counter <= last_) {
    if (last_ == std::numeric_limits<std::uint64_t>::max()) return false;  // saturated: never wraps
    counter = last_ + 1;
  }
  unsigned char* t = buf + size;
  put_trailer_header(t, key_->id(), sender_, counter);
  compute_mac(*key_, channel, buf, size, t, t + kTrailerHeaderBytes);
  last_ = counter;
  signed_any_ = true;
  return true;
}

const char* verdict_name(Verdict v) {
  switch (v) {
    case Verdict::kOk: return "ok";
    case Verdict::kUnsigned: return "unsigned";
    case Verdict::kBadMac: return "bad_mac";
    case Verdict::kStale: return "stale";
    case Verdict::kReplayed: return "replayed";
  }
  return "?";
}

std::string Verification::describe() const {
  switch (verdict) {
    case Verdict::kOk: return "authenticated (sender " + hex64(sender) + ")";
    case Verdict::kUnsigned:
      return "not authenticated: no pofkit trailer (an unsigned message, or a publisher without the bus key)";
    case Verdict::kBadMac:
      if (key_id != our_key_id)
        return "bad MAC from sender " + hex64(sender) + ": signed with another key (key id " + key_id_hex(key_id) +
               ", ours " + key_id_hex(our_key_id) + ")";
      return "bad MAC from sender " + hex64(sender) + ": forged or altered";
    case Verdict::kStale: {
      const bool behind = counter < now_us;
      return "stale: counter of sender " + hex64(sender) + " is " + seconds(behind ? now_us - counter : counter - now_us) +
             (behind ? " behind" : " ahead of") + " this host's clock (window " + seconds(window_us) +
             "): an old message, or clocks not synchronised";
    }
    case Verdict::kReplayed:
      return "replayed: counter " + std::to_string(counter) + " of sender " + hex64(sender) +
             " is not beyond the last one accepted, " + std::to_string(last_counter);
  }
  return "?";
}

Verifier::Verifier(std::shared_ptr<const Key> key, VerifierSettings settings) : key_(std::move(key)), s_(settings) {
  if (!key_) throw std::invalid_argument("Verifier: no key");
  if (s_.max_streams == 0) s_.max_streams = 1;
}

void Verifier::make_room(std::uint64_t now_us) {
  // Streams whose last counter is older than the window are no longer needed: any message at or
  // below it is stale now.
  for (auto it = last_.begin(); it != last_.end();) {
    if (it->second < now_us && now_us - it->second > s_.window_us) it = last_.erase(it);
    else ++it;
  }
  while (last_.size() >= s_.max_streams) {
    auto oldest = last_.begin();
    for (auto it = last_.begin(); it != last_.end(); ++it)
      if (it->second < oldest->second) oldest = it;
    last_.erase(oldest);
  }
}

Verification Verifier::verify(std::string_view channel, const unsigned char* data, std::size_t size,
                              std::uint64_t now_us) noexcept {
  Verification v;
  v.our_key_id = key_->id();
  v.now_us = now_us;
  v.window_us = s_.window_us;
  const auto done = [&](Verdict verdict) {
    v.verdict = verdict;
    ++counts_[static_cast<std::size_t>(verdict)];
    return v;
  };
  const std::optional<TrailerFields> t = parse_trailer(data, size);
  if (!t) return done(Verdict::kUnsigned);
  v.sender = t->sender;
  v.counter = t->counter;
  v.key_id = t->key_id;
  if (t->key_id != key_->id()) return done(Verdict::kBadMac);
  unsigned char mac[kMacBytes];
  compute_mac(*key_, channel, data, t->message_size, t->header, mac);
  if (sodium_memcmp(mac, t->mac, kMacBytes) != 0) return done(Verdict::kBadMac);
  const std::uint64_t distance = t->counter < now_us ? now_us - t->counter : t->counter - now_us;
  if (distance > s_.window_us) return done(Verdict::kStale);
  try {
    auto it = last_.find(std::pair<std::uint64_t, std::string_view>(t->sender, channel));
    if (it != last_.end()) {
      if (t->counter <= it->second) {
        v.last_counter = it->second;
        return done(Verdict::kReplayed);
      }
      it->second = t->counter;
    } else {
      if (last_.size() >= s_.max_streams) make_room(now_us);
      last_.emplace(StreamKey(t->sender, std::string(channel)), t->counter);
    }
  } catch (...) {  // out of memory: a message whose replay cannot be ruled out is not taken
    return done(Verdict::kReplayed);
  }
  v.message_size = t->message_size;
  return done(Verdict::kOk);
}

}  // namespace pof::bus::auth
