#pragma once
// The trailer of an authenticated LCM message (docs/deployment.md, "Authenticated mode"): what a
// pofkit process with a bus key appends to every LCM-encoded message it publishes, and the one
// parser of it. Header-only C++17 without libsodium or pofkit libraries (the SDK installs it), so
// that a reader without the key can still tell a signed message from a broken one (`pof spy`) and
// take the message off the front. The MAC is computed and checked by pof/bus/auth.hpp.
//
// Layout: 60 bytes after the message, integers big-endian as in LCM:
//   offset size
//    0      4   magic 0x504F4641 ("POFA")
//    4      4   version 1
//    8      4   key id: the first 4 bytes of BLAKE2b-128 keyed with the bus key over "pofkit-lcm-key-id"
//               (tells "signed with another key" from "tampered" in diagnostics; not secret)
//   12      8   sender id: random, drawn once per process start
//   20      8   counter: the sender's realtime clock [us since the Unix epoch], forced strictly
//               increasing over everything the process sends
//   28     32   MAC: BLAKE2b-256 keyed with the bus key (RFC 7693) over
//                  u32 channel length, channel, u64 message length, message, trailer bytes 0..27
//
// The message keeps its LCM encoding in front, so stock tools still take it: lcm-logger logs the
// bytes, and lcm-gen's decoders (C, C++, Java, Python) read the fields and ignore what follows.
// pofkit's bounded decoder refuses trailing bytes (pof/lcm/decode.hpp), so a pofkit receiver without
// the key counts signed messages as decode errors unless it strips the trailer first.
#include <cstddef>
#include <cstdint>
#include <optional>

namespace pof::bus::auth {

inline constexpr std::uint32_t kTrailerMagic = 0x504F4641;  // "POFA"
inline constexpr std::uint32_t kTrailerVersion = 1;
inline constexpr std::size_t kTrailerBytes = 60;
inline constexpr std::size_t kTrailerHeaderBytes = 28;  // what the MAC covers of the trailer
inline constexpr std::size_t kMacBytes = 32;

/// The fields of a trailer (the MAC stays in the message bytes).
struct TrailerFields {
  std::uint32_t key_id = 0;
  std::uint64_t sender = 0;
  std::uint64_t counter = 0;
  const unsigned char* header = nullptr;  // the 28 bytes the MAC covers
  const unsigned char* mac = nullptr;     // kMacBytes
  std::size_t message_size = 0;           // the LCM message in front of the trailer
};

namespace detail {
inline std::uint64_t get_be(const unsigned char* p, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | p[i];
  return v;
}
inline void put_be(unsigned char* p, std::uint64_t v, int n) {
  for (int i = n - 1; i >= 0; --i, v >>= 8) p[i] = static_cast<unsigned char>(v & 0xff);
}
}  // namespace detail

/// The trailer at the end of `size` bytes, when they end in one of this version (magic and version
/// in place); nullopt otherwise. Says nothing about its authenticity.
inline std::optional<TrailerFields> parse_trailer(const unsigned char* data, std::size_t size) {
  if (data == nullptr || size < kTrailerBytes) return std::nullopt;
  const unsigned char* t = data + size - kTrailerBytes;
  if (detail::get_be(t, 4) != kTrailerMagic || detail::get_be(t + 4, 4) != kTrailerVersion) return std::nullopt;
  TrailerFields f;
  f.key_id = static_cast<std::uint32_t>(detail::get_be(t + 8, 4));
  f.sender = detail::get_be(t + 12, 8);
  f.counter = detail::get_be(t + 20, 8);
  f.header = t;
  f.mac = t + kTrailerHeaderBytes;
  f.message_size = size - kTrailerBytes;
  return f;
}

/// Writes the 28 header bytes of a trailer at `at` (the MAC follows them).
inline void put_trailer_header(unsigned char* at, std::uint32_t key_id, std::uint64_t sender, std::uint64_t counter) {
  detail::put_be(at, kTrailerMagic, 4);
  detail::put_be(at + 4, kTrailerVersion, 4);
  detail::put_be(at + 8, key_id, 4);
  detail::put_be(at + 12, sender, 8);
  detail::put_be(at + 20, counter, 8);
}

}  // namespace pof::bus::auth
