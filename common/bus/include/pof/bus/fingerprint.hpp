#pragma once
// Recognising pofkit's messages in raw bytes: an LCM message starts with its type's fingerprint,
// 8 bytes big-endian (LCM type specification, "Fingerprint"), so the type is known before
// anything is decoded, whatever the channel. `pof record --check`, `pof spy` and `pof export` take
// the type from here. Header-only C++17 over the generated types.
#include <cstddef>
#include <cstdint>

#include <pof/angle_t.hpp>
#include <pof/compensator_status_t.hpp>
#include <pof/cycle_stats_t.hpp>
#include <pof/daq_status_t.hpp>
#include <pof/raw_block_t.hpp>

namespace pof::bus {

enum class MessageType { kUnknown, kRawBlock, kAngle, kCycleStats, kDaqStatus, kCompensatorStatus };

/// The first 8 bytes as a big-endian fingerprint (0 when shorter).
inline std::uint64_t fingerprint_of(const void* data, std::size_t size) {
  if (size < 8) return 0;
  const auto* p = static_cast<const unsigned char*>(data);
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return v;
}

/// Which of pofkit's types the fingerprint names (kUnknown for anything else, or fewer than 8 bytes).
inline MessageType message_type_of(const void* data, std::size_t size) {
  const std::uint64_t fp = fingerprint_of(data, size);
  if (size < 8) return MessageType::kUnknown;
  if (fp == static_cast<std::uint64_t>(pof::raw_block_t::getHash())) return MessageType::kRawBlock;
  if (fp == static_cast<std::uint64_t>(pof::angle_t::getHash())) return MessageType::kAngle;
  if (fp == static_cast<std::uint64_t>(pof::cycle_stats_t::getHash())) return MessageType::kCycleStats;
  if (fp == static_cast<std::uint64_t>(pof::daq_status_t::getHash())) return MessageType::kDaqStatus;
  if (fp == static_cast<std::uint64_t>(pof::compensator_status_t::getHash())) return MessageType::kCompensatorStatus;
  return MessageType::kUnknown;
}

/// "raw_block_t", "angle_t", ... or "?" for kUnknown.
constexpr const char* message_type_name(MessageType t) {
  switch (t) {
    case MessageType::kRawBlock: return "raw_block_t";
    case MessageType::kAngle: return "angle_t";
    case MessageType::kCycleStats: return "cycle_stats_t";
    case MessageType::kDaqStatus: return "daq_status_t";
    case MessageType::kCompensatorStatus: return "compensator_status_t";
    case MessageType::kUnknown: break;
  }
  return "?";
}

}  // namespace pof::bus
