#pragma once
// LCM's time convention, used by every pofkit message: `utime` is microseconds since the Unix
// epoch on the host's CLOCK_REALTIME (comparable across hosts running NTP/PTP).
#include <chrono>
#include <cstdint>

namespace pof::lcmutil {

inline std::int64_t now_utime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace pof::lcmutil
