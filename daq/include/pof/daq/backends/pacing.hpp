#pragma once
// Host-paced backends (the simulator, the USB-1208LS's single reads) wait for absolute deadlines
// on CLOCK_MONOTONIC counted from one start time, so rounding in each wait never accumulates
// into a drift of the scan rate.
#include <time.h>

namespace pof::daq {

/// The monotonic clock now: the start a Pacer counts from.
inline timespec monotonic_now() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t;
}

/// Sleeps until `seconds` after `start` (returns at once if that is past). EINTR ends the wait
/// early; callers check their stop flag after every wait anyway.
inline void sleep_until(const timespec& start, double seconds) {
  const auto ns = static_cast<long long>(seconds * 1e9);
  timespec due = start;
  due.tv_sec += static_cast<time_t>(ns / 1000000000LL);
  due.tv_nsec += static_cast<long>(ns % 1000000000LL);
  if (due.tv_nsec >= 1000000000L) {
    due.tv_nsec -= 1000000000L;
    ++due.tv_sec;
  }
  clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &due, nullptr);
}

/// Seconds from `start` to now on the monotonic clock.
inline double seconds_since(const timespec& start) {
  const timespec now = monotonic_now();
  return static_cast<double>(now.tv_sec - start.tv_sec) + static_cast<double>(now.tv_nsec - start.tv_nsec) * 1e-9;
}

}  // namespace pof::daq
