#pragma once
// How every pofkit process takes SIGTERM, SIGINT and SIGHUP: synchronously, in its main loop, never
// in a handler (a handler may only set a flag, and a flag misses the wake-up of a blocking call).
//
//   pof::service::SignalWaiter signals;        // first, before any thread (LCM, workers) starts
//   ... start threads: they inherit the blocked mask, so no signal is delivered to them ...
//   for (;;) {
//     const int sig = signals.wait(std::chrono::milliseconds(200));   // sigtimedwait(2)
//     if (SignalWaiter::is_stop(sig)) break;                           // SIGTERM, SIGINT
//     if (sig == SIGHUP) reload();                                     // what SIGHUP means is the caller's
//     ... periodic work ...
//   }
//
// A loop that already blocks elsewhere (poll(2) on sockets and stdin) adds fd() to its poll set and
// calls wait(0) when it is readable (signalfd(2)): the same signals, taken the same way.
//
// The signals stay blocked when the waiter is destroyed: one that arrives during the shutdown drain
// must not kill the process half-way through it (its exit code and final status would be lost).
#include <signal.h>

#include <chrono>

namespace pof::service {

class SignalWaiter {
 public:
  /// Blocks SIGTERM, SIGINT and SIGHUP in the calling thread (pthread_sigmask). Construct it before
  /// any other thread starts: a thread started earlier keeps its mask and the kernel may deliver a
  /// signal there, where the default action ends the process.
  SignalWaiter();
  ~SignalWaiter();
  SignalWaiter(const SignalWaiter&) = delete;
  SignalWaiter& operator=(const SignalWaiter&) = delete;

  /// Waits up to `timeout` (0: only looks) for one of the signals and takes it: returns SIGTERM,
  /// SIGINT or SIGHUP, or 0 when none arrived in time.
  [[nodiscard]] int wait(std::chrono::nanoseconds timeout) const;

  /// A file descriptor that polls readable while one of the signals is pending (a signalfd(2),
  /// opened on first use, closed by the destructor). Take the signal with wait(0).
  [[nodiscard]] int fd();

  /// SIGTERM (systemd's stop, kill) or SIGINT (Ctrl-C).
  [[nodiscard]] static bool is_stop(int sig) noexcept { return sig == SIGTERM || sig == SIGINT; }

 private:
  sigset_t set_{};
  int fd_ = -1;
};

/// For a process that writes files or pipes: SIGXFSZ (a file over RLIMIT_FSIZE) and SIGPIPE (a
/// closed reader) are ignored, so the write fails with EFBIG/EPIPE and the caller reports it,
/// instead of the signal killing the process mid-write.
void ignore_write_signals() noexcept;

}  // namespace pof::service
