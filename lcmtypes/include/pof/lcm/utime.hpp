#pragma once
// LCM's time convention, used by every pofkit message: `utime` is microseconds since the Unix
// epoch on the host's CLOCK_REALTIME (comparable across hosts running NTP/PTP).
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <string>

namespace pof::lcmutil {

inline std::int64_t now_utime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

/// `utime` as ISO 8601 UTC, "2026-11-23T15:04:05.123456Z" (microseconds optional), for manifests
/// and reports a person reads.
inline std::string iso_utc(std::int64_t utime, bool microseconds = true) {
  const auto t = static_cast<std::time_t>(utime / 1000000);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char date[40];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S", &tm);
  char out[64];
  if (microseconds) {
    std::snprintf(out, sizeof out, "%s.%06lldZ", date, static_cast<long long>(utime % 1000000));
  } else {
    std::snprintf(out, sizeof out, "%sZ", date);
  }
  return out;
}

}  // namespace pof::lcmutil
