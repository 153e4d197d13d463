#include "pof/recorder/pof_messages.hpp"

#include <climits>

#include <pof/angle_t.hpp>
#include <pof/compensator_status_t.hpp>
#include <pof/cycle_stats_t.hpp>
#include <pof/daq_status_t.hpp>
#include <pof/raw_block_t.hpp>

#include "pof/bus/fingerprint.hpp"
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

std::optional<int64_t> pof_seq_decoded(const void* data, std::size_t size) {
  switch (bus::message_type_of(data, size)) {
    case bus::MessageType::kRawBlock: return decode_seq<pof::raw_block_t>(data, size);
    case bus::MessageType::kAngle: return decode_seq<pof::angle_t>(data, size);
    case bus::MessageType::kCycleStats: return decode_seq<pof::cycle_stats_t>(data, size);
    case bus::MessageType::kDaqStatus: return decode_seq<pof::daq_status_t>(data, size);
    case bus::MessageType::kCompensatorStatus: return decode_seq<pof::compensator_status_t>(data, size);
    case bus::MessageType::kUnknown: break;
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
  switch (bus::message_type_of(data, size)) {
    case bus::MessageType::kRawBlock:
    case bus::MessageType::kAngle: at = 24; break;
    case bus::MessageType::kCycleStats:
    case bus::MessageType::kDaqStatus:
    case bus::MessageType::kCompensatorStatus: at = 16; break;
    case bus::MessageType::kUnknown: return std::nullopt;
  }
  if (size < at + 8) return std::nullopt;
  return static_cast<int64_t>(bus::fingerprint_of(static_cast<const unsigned char*>(data) + at, 8));  // big-endian, as seq is
}

}  // namespace pof::recorder
