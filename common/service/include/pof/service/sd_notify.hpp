#pragma once
// systemd integration for pofkit daemons (deploy/*.service are Type=notify with WatchdogSec).
//
//   ServiceNotifier n;             // reads NOTIFY_SOCKET / WATCHDOG_USEC once
//   ... setup ...
//   n.ready("streaming");          // READY=1: systemd starts the units ordered after us
//   loop { if (healthy) n.watchdog_if_due(); }   // WATCHDOG=1 at half the WatchdogSec period
//   n.stopping();                  // STOPPING=1 before the (possibly long) drain
//
// Feed the watchdog only from a loop that proves the service works (e.g. after checking that the
// worker threads' heartbeats moved), never from a timer thread of its own: a hung daemon must be
// restarted (Restart=on-failure; see sd_watchdog_enabled(3)).
//
// Outside systemd every call is a cheap no-op. Thread safety: call from one thread.
#include <chrono>
#include <cstdint>
#include <string>

namespace pof::service {

class ServiceNotifier {
 public:
  ServiceNotifier();

  /// True when started by systemd with a notify socket.
  [[nodiscard]] bool enabled() const { return enabled_; }
  /// The watchdog period systemd expects (0 when WatchdogSec is not set).
  [[nodiscard]] std::chrono::microseconds watchdog_period() const { return watchdog_; }

  void ready(const std::string& status = {});
  void status(const std::string& status);
  /// Sends WATCHDOG=1 when half the period has passed since the last one. Returns true when sent.
  bool watchdog_if_due();
  void watchdog();
  void stopping(const std::string& status = {});
  /// Reports a fatal errno to systemd (ERRNO=), shown by systemctl status.
  void errno_status(int err, const std::string& status);

 private:
  void send(const std::string& state);

  bool enabled_ = false;
  std::chrono::microseconds watchdog_{0};
  std::chrono::steady_clock::time_point last_watchdog_{};
};

}  // namespace pof::service
