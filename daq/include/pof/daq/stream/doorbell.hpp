#pragma once
// The acquisition thread's "a block is ready" signal to the publisher thread.
//
// ring() is called on the USB event thread for every block: it never blocks, allocates or locks
// (one atomic add, plus one FUTEX_WAKE only while the publisher sleeps). wait_until() sleeps in
// the kernel until a ring or the deadline (the 1-Hz status), and wakes within the scheduler's
// latency of a ring.
//
// Why not std::counting_semaphore: libstdc++ 12's timed acquire (try_acquire_until) does not block
// on a futex; it polls with a back-off (yield, then sleep_for(elapsed / 2), then 64-ms sleeps), so
// the publisher both burnt CPU and woke up to half its waiting time late. Measured on the virtual
// USB-6009 at 48 kS/s: BENCHMARKS.md, "pof-daqd: the publisher's wake-up".
//
// One waiter (the publisher), any number of ringers.
#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <climits>
#include <cstdint>
#include <ctime>

namespace pof::daq {

class Doorbell {
 public:
  /// Wakes the waiter (or makes its next wait return at once). Async-signal-safe, lock-free.
  void ring() noexcept {
    rings_.fetch_add(1, std::memory_order_seq_cst);
    // Dekker pairing with wait_until(): either the waiter sees the new count before it sleeps, or
    // this sees it waiting and wakes it (the kernel re-checks the count under its futex lock).
    if (waiting_.load(std::memory_order_seq_cst)) futex(FUTEX_WAKE_PRIVATE, INT_MAX, nullptr);
  }

  /// True (and consumes the rings) if rung since the last true return; never sleeps.
  bool try_wait() noexcept { return wait_until(std::chrono::steady_clock::time_point::min()); }

  /// Returns true once rung since the previous call returned true, false at the deadline.
  bool wait_until(std::chrono::steady_clock::time_point deadline) noexcept {
    for (;;) {
      const std::uint32_t r = rings_.load(std::memory_order_seq_cst);
      if (r != seen_) {
        seen_ = r;
        return true;
      }
      const auto now = std::chrono::steady_clock::now();  // CLOCK_MONOTONIC, as FUTEX_WAIT's timeout
      if (now >= deadline) return false;
      const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - now).count();
      timespec rel{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
      waiting_.store(true, std::memory_order_seq_cst);
      futex(FUTEX_WAIT_PRIVATE, r, &rel);  // returns at once if the count moved past r
      waiting_.store(false, std::memory_order_relaxed);
    }
  }

 private:
  long futex(int op, std::uint32_t val, const timespec* timeout) noexcept {
    return syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&rings_), op, val, timeout, nullptr, 0);
  }
  static_assert(sizeof(std::atomic<std::uint32_t>) == sizeof(std::uint32_t) &&
                std::atomic<std::uint32_t>::is_always_lock_free, "a futex word is a plain 32-bit int");

  std::atomic<std::uint32_t> rings_{0};
  std::atomic<bool> waiting_{false};
  std::uint32_t seen_ = 0;  // the waiter's own
};

}  // namespace pof::daq
