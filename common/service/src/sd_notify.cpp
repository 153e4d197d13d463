#include "pof/service/sd_notify.hpp"

#include <systemd/sd-daemon.h>

#include <cstdlib>

namespace pof::service {

ServiceNotifier::ServiceNotifier() {
  const char* sock = std::getenv("NOTIFY_SOCKET");
  enabled_ = sock != nullptr && *sock != '\0';
  uint64_t usec = 0;
  // unset_environment = 0: child processes we may start are not ours to supervise, but keeping the
  // variables lets a re-exec keep working.
  if (sd_watchdog_enabled(0, &usec) > 0) watchdog_ = std::chrono::microseconds(static_cast<int64_t>(usec));
}

void ServiceNotifier::send(const std::string& state) {
  if (enabled_) sd_notify(0, state.c_str());
}

void ServiceNotifier::ready(const std::string& status) {
  send(status.empty() ? std::string("READY=1") : "READY=1\nSTATUS=" + status);
  last_watchdog_ = std::chrono::steady_clock::now();
}

void ServiceNotifier::status(const std::string& status) { send("STATUS=" + status); }

void ServiceNotifier::watchdog() {
  send("WATCHDOG=1");
  last_watchdog_ = std::chrono::steady_clock::now();
}

bool ServiceNotifier::watchdog_if_due() {
  if (watchdog_.count() == 0) return false;
  if (std::chrono::steady_clock::now() - last_watchdog_ < watchdog_ / 2) return false;
  watchdog();
  return true;
}

void ServiceNotifier::stopping(const std::string& status) {
  send(status.empty() ? std::string("STOPPING=1") : "STOPPING=1\nSTATUS=" + status);
}

void ServiceNotifier::errno_status(int err, const std::string& status) {
  send("ERRNO=" + std::to_string(err) + "\nSTATUS=" + status);
}

}  // namespace pof::service
