#include "pof/recorder/pof_messages.hpp"

#include <climits>

#include <pof/angle_t.hpp>
#include <pof/compensator_status_t.hpp>
#include <pof/cycle_stats_t.hpp>
#include <pof/daq_status_t.hpp>
#include <pof/raw_block_t.hpp>

#include "pof/lcm/decode.hpp"

namespace pof::recorder {
namespace {

template <class T>
std::optional<int64_t> decode_seq(const void* data, std::size_t size) {
  T m;
  if (!lcmutil::decode(data, size, m)) return std::nullopt;  // bounded: lengths are checked first
  return m.seq;
}

}  // namespace

uint64_t fingerprint_of(const void* data, std::size_t size) {
  if (size < 8) return 0;
  const auto* p = static_cast<const unsigned char*>(data);
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return v;
}

PofType pof_type_of(const void* data, std::size_t size) {
  const uint64_t fp = fingerprint_of(data, size);
  if (fp == 0) return PofType::kUnknown;
  if (fp == static_cast<uint64_t>(pof::raw_block_t::getHash())) return PofType::kRawBlock;
  if (fp == static_cast<uint64_t>(pof::angle_t::getHash())) return PofType::kAngle;
  if (fp == static_cast<uint64_t>(pof::cycle_stats_t::getHash())) return PofType::kCycleStats;
  if (fp == static_cast<uint64_t>(pof::daq_status_t::getHash())) return PofType::kDaqStatus;
  if (fp == static_cast<uint64_t>(pof::compensator_status_t::getHash())) return PofType::kCompensatorStatus;
  return PofType::kUnknown;
}

const char* pof_type_name(PofType t) {
  switch (t) {
    case PofType::kRawBlock: return "raw_block_t";
    case PofType::kAngle: return "angle_t";
    case PofType::kCycleStats: return "cycle_stats_t";
    case PofType::kDaqStatus: return "daq_status_t";
    case PofType::kCompensatorStatus: return "compensator_status_t";
    case PofType::kUnknown: break;
  }
  return "?";
}

std::optional<int64_t> pof_seq_decoded(const void* data, std::size_t size) {
  switch (pof_type_of(data, size)) {
    case PofType::kRawBlock: return decode_seq<pof::raw_block_t>(data, size);
    case PofType::kAngle: return decode_seq<pof::angle_t>(data, size);
    case PofType::kCycleStats: return decode_seq<pof::cycle_stats_t>(data, size);
    case PofType::kDaqStatus: return decode_seq<pof::daq_status_t>(data, size);
    case PofType::kCompensatorStatus: return decode_seq<pof::compensator_status_t>(data, size);
    case PofType::kUnknown: break;
  }
  return std::nullopt;
}

// The recorder sees every message at up to 100k msg/s; a full decode of a raw block allocates a
// vector per scan. `seq` sits at a fixed offset after the fingerprint (LCM encodes fields in
// declaration order, big-endian, lcmtypes/*.lcm): raw_block_t and angle_t after utime and
// publish_utime (byte 24), cycle_stats_t, daq_status_t and compensator_status_t after utime
// (byte 16). A unit test
// checks this against pof_seq_decoded() so a reordered .lcm file cannot go unnoticed.
std::optional<int64_t> pof_seq(const void* data, std::size_t size) {
  std::size_t at = 0;
  switch (pof_type_of(data, size)) {
    case PofType::kRawBlock:
    case PofType::kAngle: at = 24; break;
    case PofType::kCycleStats:
    case PofType::kDaqStatus:
    case PofType::kCompensatorStatus: at = 16; break;
    case PofType::kUnknown: return std::nullopt;
  }
  if (size < at + 8) return std::nullopt;
  return static_cast<int64_t>(fingerprint_of(static_cast<const unsigned char*>(data) + at, 8));
}

}  // namespace pof::recorder
