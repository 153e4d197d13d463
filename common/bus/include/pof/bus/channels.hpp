#pragma once
// pofkit's LCM channel names: the one place they are spelt. Every stream is POF_<STREAM>, suffixed
// with _<SENSOR_ID> when the publisher serves a named sensor (docs/deployment.md, "Processes and channels"):
//
//   Stream              channel                             type                    publisher
//   kRaw                POF_RAW[_<ID>]                      raw_block_t             pof-daqd
//   kDaqStatus          POF_DAQ_STATUS[_<ID>]               daq_status_t            pof-daqd
//   kAngle              POF_ANGLE[_<ID>]                    angle_t                 pof-compensatord
//   kStats              POF_STATS[_<ID>]                    cycle_stats_t           pof-compensatord
//   kCompensatorStatus  POF_COMPENSATOR_STATUS[_<ID>]       compensator_status_t    pof-compensatord
//
// Header-only C++17 (the SDK installs it, examples/cpp_client uses it).
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace pof::bus {

enum class Stream { kRaw, kDaqStatus, kAngle, kStats, kCompensatorStatus };

inline constexpr Stream kStreams[] = {Stream::kRaw, Stream::kDaqStatus, Stream::kAngle, Stream::kStats,
                                      Stream::kCompensatorStatus};

/// "POF_RAW", "POF_DAQ_STATUS", ...: the channel without a sensor id.
constexpr std::string_view stream_base(Stream s) {
  switch (s) {
    case Stream::kRaw: return "POF_RAW";
    case Stream::kDaqStatus: return "POF_DAQ_STATUS";
    case Stream::kAngle: return "POF_ANGLE";
    case Stream::kStats: return "POF_STATS";
    case Stream::kCompensatorStatus: return "POF_COMPENSATOR_STATUS";
  }
  return "";
}

/// LCM's longest channel name (lcm.h, LCM_MAX_CHANNEL_NAME_LENGTH): a longer one is refused at
/// every publish.
inline constexpr std::size_t kMaxChannelChars = 63;
/// The longest sensor id: the longest channel, POF_COMPENSATOR_STATUS_<ID>, within LCM's limit.
inline constexpr std::size_t kMaxSensorIdChars = kMaxChannelChars - stream_base(Stream::kCompensatorStatus).size() - 1;

/// Why `id` cannot suffix pofkit's channels, "" when it can: upper-case letters, digits and '_'
/// (channel names are upper case, and a subscriber's channel regex must not read it as one), at
/// most kMaxSensorIdChars. The message ends before the value, which the caller quotes.
inline std::string sensor_id_problem(std::string_view id) {
  for (const char ch : id)
    if (!((ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_')) return "expected upper-case letters, digits and '_'";
  if (id.size() > kMaxSensorIdChars)
    return "expected at most " + std::to_string(kMaxSensorIdChars) + " characters (POF_COMPENSATOR_STATUS_<id> must fit LCM's " +
           std::to_string(kMaxChannelChars) + ")";
  return {};
}

/// (kAngle, "LEFT_KNEE") -> "POF_ANGLE_LEFT_KNEE"; no suffix for an empty sensor id.
inline std::string channel(Stream s, std::string_view sensor_id = {}) {
  std::string c(stream_base(s));
  if (!sensor_id.empty()) c.append("_").append(sensor_id);
  return c;
}

/// A channel name taken apart: the inverse of channel().
struct ChannelName {
  Stream stream = Stream::kRaw;
  std::string sensor_id;
};

/// "POF_RAW_LEFT_KNEE" -> {kRaw, "LEFT_KNEE"}; nullopt for a channel that is none of pofkit's
/// streams ("POF_RAWX", "POF_RAW_", "FOREIGN"). No stream name is a prefix of another, so the
/// answer is unique.
inline std::optional<ChannelName> parse_channel(std::string_view ch) {
  for (const Stream s : kStreams) {
    const std::string_view base = stream_base(s);
    if (ch.substr(0, base.size()) != base) continue;
    const std::string_view rest = ch.substr(base.size());
    if (rest.empty()) return ChannelName{s, {}};
    if (rest.size() > 1 && rest[0] == '_') return ChannelName{s, std::string(rest.substr(1))};
  }
  return std::nullopt;
}

}  // namespace pof::bus
