// fuzz-link: pof_bus
// The authenticated mode's receive side (common/bus/include/pof/bus/auth_trailer.hpp, auth.hpp):
// parse_trailer() and Verifier::verify(), with a fixed key. Random bytes almost never carry a
// valid MAC, so the input is read two ways (fuzz_auth_input.hpp): as one message off the bus, and
// as a script in which senders with the key sign messages made of the input's bytes, alter them,
// and deliver them again, so that every verdict comes up. Properties:
//  - the trailer is there exactly when its magic and version end the message; its fields are the
//    bytes they are read from (put_trailer_header writes them back), and the MAC covers what
//    compute_mac() says: the verdict is exactly the one the order in auth.hpp gives;
//  - a message accepted is the input's bytes in front of the trailer, unchanged;
//  - delivered again it is a replay; on another channel, or with any byte altered, it is refused;
//    a message signed now is accepted unless its counter is outside the window;
//  - an older message delivered again is never accepted while the verifier has had no cause to
//    forget a stream (at most max_streams of them); the verdicts counted add up; describe() is
//    bounded.
// Seeds: tests/fuzz/corpus/auth/ (fuzz_seeds writes them).
#include <array>
#include <cstdint>
#include <cstring>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "fuzz_auth_input.hpp"
#include "fuzz_check.hpp"
#include "pof/bus/auth.hpp"
#include "pof/bus/auth_trailer.hpp"

namespace {

namespace in = pof::fuzz::auth_input;
namespace auth = pof::bus::auth;
using auth::Verdict;

struct Bytes {
  const std::uint8_t* p;
  std::size_t n;
  std::size_t at = 0;
  [[nodiscard]] bool more() const { return at < n; }
  std::uint8_t u8() { return at < n ? p[at++] : 0; }
  std::pair<const std::uint8_t*, std::size_t> take(std::size_t k) {
    k = std::min(k, n - at);
    const std::uint8_t* q = p + at;
    at += k;
    return {q, k};
  }
};

const std::shared_ptr<const auth::Key>& key() {
  static const auto k = in::key();
  return k;
}

std::uint64_t distance(std::uint64_t a, std::uint64_t b) { return a < b ? b - a : a - b; }

// What verify() said, checked against what it may say of `data` on `channel` at kNow-like `now`
// by the rules of auth.hpp, for a verifier that has accepted nothing from this sender on this
// channel since `fresh` (then kReplayed is impossible).
void check_verdict(const auth::Verification& v, std::string_view channel, const std::uint8_t* data, std::size_t size,
                   std::uint64_t now, bool fresh) {
  const std::string text = v.describe();
  FUZZ_CHECK(!text.empty() && text.size() < 512);
  const std::optional<auth::TrailerFields> t = auth::parse_trailer(data, size);
  FUZZ_CHECK(t.has_value() == (v.verdict != Verdict::kUnsigned));
  if (!t) return;
  FUZZ_CHECK(t->message_size + auth::kTrailerBytes == size);
  FUZZ_CHECK(t->header == data + t->message_size && t->mac == t->header + auth::kTrailerHeaderBytes);
  std::array<unsigned char, auth::kTrailerHeaderBytes> header{};
  auth::put_trailer_header(header.data(), t->key_id, t->sender, t->counter);
  FUZZ_CHECK(std::memcmp(header.data(), t->header, header.size()) == 0);
  FUZZ_CHECK(v.sender == t->sender && v.counter == t->counter && v.key_id == t->key_id);
  std::array<unsigned char, auth::kMacBytes> mac{};
  auth::compute_mac(*key(), channel, data, t->message_size, t->header, mac.data());
  const bool authentic = t->key_id == key()->id() && std::memcmp(mac.data(), t->mac, mac.size()) == 0;
  if (!authentic) {
    FUZZ_CHECK(v.verdict == Verdict::kBadMac);
    return;
  }
  if (distance(t->counter, now) > in::kWindowUs) {
    FUZZ_CHECK(v.verdict == Verdict::kStale);
    return;
  }
  FUZZ_CHECK(v.verdict == Verdict::kOk || (!fresh && v.verdict == Verdict::kReplayed));
  if (v.ok()) FUZZ_CHECK(v.message_size == t->message_size);
}

std::uint64_t calls(const auth::Verifier& v) {
  std::uint64_t n = 0;
  for (const Verdict d : {Verdict::kOk, Verdict::kUnsigned, Verdict::kBadMac, Verdict::kStale, Verdict::kReplayed})
    n += v.count(d);
  return n;
}

void as_received(Bytes b) {
  const auto [ch, ch_len] = b.take(b.u8() % 64U);
  const std::string_view channel(reinterpret_cast<const char*>(ch), ch_len);
  const auto [data, size] = b.take(b.n);
  auth::Verifier v(key(), {in::kWindowUs, in::kMaxStreams});
  const auth::Verification r = v.verify(channel, data, size, in::kNow);
  check_verdict(r, channel, data, size, in::kNow, true);
  if (!r.ok()) return;
  const auth::Verification again = v.verify(channel, data, size, in::kNow);
  FUZZ_CHECK(again.verdict == Verdict::kReplayed && again.last_counter == r.counter);
  const std::string other = std::string(channel) + "_";
  FUZZ_CHECK(v.verify(other, data, size, in::kNow).verdict == Verdict::kBadMac);
  FUZZ_CHECK(calls(v) == 3 && v.count(Verdict::kOk) == 1);
}

struct Sent {
  std::vector<unsigned char> bytes;  // message + trailer
  std::size_t channel;
};

void script(Bytes b) {
  auth::Verifier v(key(), {in::kWindowUs, in::kMaxStreams});
  std::vector<std::unique_ptr<auth::Signer>> signers;
  for (const std::uint64_t id : in::kSenders) signers.push_back(std::make_unique<auth::Signer>(key(), id));
  std::uint64_t now = in::kNow;
  std::uint64_t n_calls = 0;
  std::vector<Sent> accepted;
  std::set<std::pair<std::size_t, std::size_t>> streams;  // (sender, channel) ever accepted
  while (b.more()) {
    const std::uint8_t control = b.u8();
    const auto step = static_cast<in::Step>(control & 3U);
    if (step == in::kReplayOld || step == in::kOtherChannel) {
      const std::uint8_t index = b.u8();
      if (accepted.empty()) continue;
      const Sent& s = accepted[index % accepted.size()];
      const std::size_t ch = step == in::kReplayOld ? s.channel : (s.channel + 1) % in::kChannels.size();
      const auth::Verification r = v.verify(in::kChannels[ch], s.bytes.data(), s.bytes.size(), now);
      ++n_calls;
      check_verdict(r, in::kChannels[ch], s.bytes.data(), s.bytes.size(), now, false);
      if (step == in::kOtherChannel) FUZZ_CHECK(r.verdict == Verdict::kBadMac);
      // Nothing forgotten yet: an old message is a replay or stale, never new.
      if (step == in::kReplayOld && streams.size() <= in::kMaxStreams) FUZZ_CHECK(r.verdict == Verdict::kReplayed || r.verdict == Verdict::kStale);
      continue;
    }
    const std::size_t sender = (control >> 2) & 3U;
    const std::size_t ch = (control >> 4) & 3U;
    now += std::uint64_t{b.u8()} * 1000;
    const auto skew = (static_cast<std::int64_t>(b.u8()) - 128) * static_cast<std::int64_t>(in::kSkewStepUs);
    const auto [msg, len] = b.take(b.u8());
    Sent s{std::vector<unsigned char>(len + auth::kTrailerBytes), ch};
    if (len > 0) std::memcpy(s.bytes.data(), msg, len);
    FUZZ_CHECK(signers[sender]->sign(in::kChannels[ch], s.bytes.data(), len, static_cast<std::uint64_t>(static_cast<std::int64_t>(now) + skew)));
    const std::uint64_t counter = signers[sender]->last_counter();
    const bool altered = (control & in::kAlter) != 0;
    if (altered) {
      const std::size_t at = b.u8() % s.bytes.size();
      const std::uint8_t x = b.u8();
      s.bytes[at] ^= x == 0 ? 1 : x;
    }
    const auth::Verification r = v.verify(in::kChannels[ch], s.bytes.data(), s.bytes.size(), now);
    ++n_calls;
    check_verdict(r, in::kChannels[ch], s.bytes.data(), s.bytes.size(), now, true);
    if (altered) {
      FUZZ_CHECK(r.verdict == Verdict::kUnsigned || r.verdict == Verdict::kBadMac);
    } else {
      // Signed just now by a sender whose counter never goes back: new, unless out of the window.
      FUZZ_CHECK(r.verdict == (distance(counter, now) > in::kWindowUs ? Verdict::kStale : Verdict::kOk));
    }
    if (r.ok()) {
      FUZZ_CHECK(r.message_size == len && (len == 0 || std::memcmp(s.bytes.data(), msg, len) == 0));
      streams.emplace(sender, ch);
    }
    if ((control & in::kTwice) != 0) {
      const Verdict again = v.verify(in::kChannels[ch], s.bytes.data(), s.bytes.size(), now).verdict;
      ++n_calls;
      FUZZ_CHECK(again == (r.ok() ? Verdict::kReplayed : r.verdict));
    }
    if (r.ok()) accepted.push_back(std::move(s));
  }
  FUZZ_CHECK(calls(v) == n_calls && v.streams() <= in::kMaxStreams);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  Bytes b{data, size, 1};
  if ((data[0] & 1U) == 0) as_received(b);
  else script(b);
  return 0;
}
