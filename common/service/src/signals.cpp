#include "pof/service/signals.hpp"

#include <pthread.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <cerrno>
#include <ctime>
#include <system_error>

namespace pof::service {

SignalWaiter::SignalWaiter() {
  sigemptyset(&set_);
  sigaddset(&set_, SIGTERM);
  sigaddset(&set_, SIGINT);
  sigaddset(&set_, SIGHUP);
  if (const int err = pthread_sigmask(SIG_BLOCK, &set_, nullptr); err != 0)
    throw std::system_error(err, std::generic_category(), "pthread_sigmask");
}

SignalWaiter::~SignalWaiter() {
  if (fd_ >= 0) ::close(fd_);
}

int SignalWaiter::wait(std::chrono::nanoseconds timeout) const {
  if (timeout < std::chrono::nanoseconds::zero()) timeout = std::chrono::nanoseconds::zero();
  const auto s = std::chrono::duration_cast<std::chrono::seconds>(timeout);
  const timespec ts{static_cast<time_t>(s.count()), static_cast<long>((timeout - s).count())};
  const int sig = sigtimedwait(&set_, nullptr, &ts);
  // -1: EAGAIN (timed out) or EINTR (a signal outside the set ran a handler): nothing to report.
  return sig > 0 ? sig : 0;
}

int SignalWaiter::fd() {
  if (fd_ < 0) {
    fd_ = ::signalfd(-1, &set_, SFD_CLOEXEC | SFD_NONBLOCK);
    if (fd_ < 0) throw std::system_error(errno, std::generic_category(), "signalfd");
  }
  return fd_;
}

void ignore_write_signals() noexcept {
  struct sigaction sa {};
  sa.sa_handler = SIG_IGN;
  ::sigemptyset(&sa.sa_mask);
  ::sigaction(SIGXFSZ, &sa, nullptr);
  ::sigaction(SIGPIPE, &sa, nullptr);
}

}  // namespace pof::service
