#pragma once
// The input format of fuzz_auth.cpp, shared with the seed writer (fuzz_seeds.cpp): the fixed bus
// key, the receiver's clock, and how the bytes are read.
//
//   byte 0, bit 0 clear  "as received": byte 1 = channel length L (mod 64), L channel bytes, and
//                        the rest is one message as it came off the bus, verified at kNow.
//   byte 0, bit 0 set    "script": steps until the bytes run out, each one control byte, then
//                        per kind (control & 3):
//     kSign, kSign2      sender (control >> 2 & 3) signs, on channel kChannels[control >> 4 & 3],
//                        a message of L bytes: [advance: the clock moves u8 ms] [skew: the
//                        sender's clock is (u8 - 128) x 25 ms off] [L] [L bytes]; when control bit
//                        6 is set [position u8] [xor u8] alter one byte of what was signed; bit 7
//                        set: the same bytes are delivered a second time right after
//     kReplayOld         [index u8] one of the messages accepted so far is delivered again
//     kOtherChannel      [index u8] one of them is delivered on another channel
#include <array>
#include <cstdint>
#include <memory>
#include <string_view>

#include "pof/bus/auth.hpp"

namespace pof::fuzz::auth_input {

inline constexpr std::uint64_t kNow = 1'800'000'000'000'000;  // 2027, us since the epoch
inline constexpr std::uint64_t kWindowUs = 2'000'000;        // VerifierSettings' default
inline constexpr std::size_t kMaxStreams = 3;                // small, so that eviction comes up
inline constexpr std::uint64_t kSkewStepUs = 25'000;
inline constexpr std::array<std::string_view, 4> kChannels{"POF_RAW", "POF_RAW_LEFT_KNEE", "POF_ANGLE", "X"};
inline constexpr std::array<std::uint64_t, 4> kSenders{0x0123456789abcdefULL, 0xfedcba9876543210ULL, 1, 0};
enum Step : std::uint8_t { kSign = 0, kSign2 = 1, kReplayOld = 2, kOtherChannel = 3 };
inline constexpr std::uint8_t kAlter = 0x40;
inline constexpr std::uint8_t kTwice = 0x80;

/// The fixed bus key of the fuzz target: bytes 0x5a, 0x5b, ...
inline std::shared_ptr<const pof::bus::auth::Key> key(unsigned char first = 0x5a) {
  std::array<unsigned char, pof::bus::auth::Key::kBytes> k{};
  for (std::size_t i = 0; i < k.size(); ++i) k[i] = static_cast<unsigned char>(first + i);
  return std::make_shared<const pof::bus::auth::Key>(k.data(), k.size());
}

}  // namespace pof::fuzz::auth_input
