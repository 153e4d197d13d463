#pragma once
// Hand-made LCM udpm:// datagrams (the wire format of common/bus/include/pof/bus/udpm_receiver.hpp, LCM's
// "UDP Multicast Protocol Description"), what a forger or a test sends: the unit test of
// pof::bus::parse_udpm_datagram, the hostile-datagram tests and the udpm_datagram fuzz target (its
// round trip and its seeds). Fields are written as given, checked or not.
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

namespace pof::test {

inline void put_be(std::vector<unsigned char>& d, std::uint64_t v, int bytes) {
  for (int i = bytes - 1; i >= 0; --i) d.push_back(static_cast<unsigned char>(v >> (8 * i)));
}

/// LC02: magic, sequence, channel '\0', payload.
inline std::vector<unsigned char> udpm_short(std::uint32_t seq, std::string_view channel,
                                             const std::vector<unsigned char>& payload) {
  std::vector<unsigned char> d;
  put_be(d, 0x4C433032, 4);
  put_be(d, seq, 4);
  d.insert(d.end(), channel.begin(), channel.end());
  d.push_back(0);
  d.insert(d.end(), payload.begin(), payload.end());
  return d;
}

/// LC03: magic, sequence, message size, offset, fragment number and count; then `channel` '\0'
/// when `channel` is not empty (fragment 0 carries it), then the fragment's bytes.
inline std::vector<unsigned char> udpm_fragment(std::uint32_t seq, std::uint32_t message_size, std::uint32_t offset,
                                                std::uint16_t number, std::uint16_t count, std::string_view channel,
                                                const std::vector<unsigned char>& body) {
  std::vector<unsigned char> d;
  put_be(d, 0x4C433033, 4);
  put_be(d, seq, 4);
  put_be(d, message_size, 4);
  put_be(d, offset, 4);
  put_be(d, number, 2);
  put_be(d, count, 2);
  if (!channel.empty()) {
    d.insert(d.end(), channel.begin(), channel.end());
    d.push_back(0);
  }
  d.insert(d.end(), body.begin(), body.end());
  return d;
}

/// `message` on `channel` as a sender fragments it: at most `budget` bytes after each 20-byte
/// header, fragment 0 spending channel.size() + 1 of them on the channel, offsets in order
/// (budget > channel.size() + 1).
inline std::vector<std::vector<unsigned char>> udpm_fragments(std::uint32_t seq, std::string_view channel,
                                                              const std::vector<unsigned char>& message,
                                                              std::size_t budget) {
  std::vector<std::size_t> cuts{0};  // start offset of every fragment
  std::size_t at = budget - channel.size() - 1;
  while (at < message.size()) {
    cuts.push_back(at);
    at += budget;
  }
  std::vector<std::vector<unsigned char>> out;
  for (std::size_t i = 0; i < cuts.size(); ++i) {
    const std::size_t end = i + 1 < cuts.size() ? cuts[i + 1] : message.size();
    const std::vector<unsigned char> body(message.begin() + static_cast<std::ptrdiff_t>(cuts[i]),
                                          message.begin() + static_cast<std::ptrdiff_t>(end));
    out.push_back(udpm_fragment(seq, static_cast<std::uint32_t>(message.size()), static_cast<std::uint32_t>(cuts[i]),
                                static_cast<std::uint16_t>(i), static_cast<std::uint16_t>(cuts.size()),
                                i == 0 ? channel : std::string_view{}, body));
  }
  return out;
}

}  // namespace pof::test
