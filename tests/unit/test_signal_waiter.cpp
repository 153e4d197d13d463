// pof::service::SignalWaiter: SIGTERM, SIGINT and SIGHUP blocked and taken synchronously. Every
// test raises a real signal at this process: were it not blocked, its default action would end the
// test binary, so a missing mask fails loudly. (gtest_discover_tests runs each test in its own
// process.)
#include <gtest/gtest.h>

#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "pof/service/signals.hpp"

using pof::service::SignalWaiter;
using std::chrono::milliseconds;
using std::chrono::nanoseconds;

namespace {

bool blocked_here(int sig) {
  sigset_t cur;
  sigemptyset(&cur);
  pthread_sigmask(SIG_BLOCK, nullptr, &cur);
  return sigismember(&cur, sig) == 1;
}

}  // namespace

TEST(SignalWaiter, RaisedSighupIsReturnedOnce) {
  const SignalWaiter w;
  ASSERT_EQ(raise(SIGHUP), 0);
  EXPECT_EQ(w.wait(nanoseconds::zero()), SIGHUP);
  EXPECT_EQ(w.wait(nanoseconds::zero()), 0);  // taken: not reported twice
}

TEST(SignalWaiter, TimeoutReturnsNoneAfterWaiting) {
  const SignalWaiter w;
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(w.wait(milliseconds(20)), 0);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, milliseconds(20));  // it waited, it did not spin
}

TEST(SignalWaiter, ThreadsStartedAfterItInheritTheMask) {
  const SignalWaiter w;
  bool term = false, intr = false, hup = false;
  std::thread t([&] {
    term = blocked_here(SIGTERM);
    intr = blocked_here(SIGINT);
    hup = blocked_here(SIGHUP);
  });
  t.join();
  EXPECT_TRUE(term);
  EXPECT_TRUE(intr);
  EXPECT_TRUE(hup);
}

TEST(SignalWaiter, ProcessSignalFromAnotherThreadWakesTheWait) {
  const SignalWaiter w;
  std::thread sender([] { kill(getpid(), SIGTERM); });  // what systemd's stop does
  const int sig = w.wait(std::chrono::seconds(10));      // returns as soon as it arrives
  sender.join();
  EXPECT_EQ(sig, SIGTERM);
  EXPECT_TRUE(SignalWaiter::is_stop(sig));
  EXPECT_FALSE(SignalWaiter::is_stop(SIGHUP));
  EXPECT_FALSE(SignalWaiter::is_stop(0));
}

TEST(SignalWaiter, FdPollsReadableWhileASignalIsPending) {
  SignalWaiter w;
  pollfd p{w.fd(), POLLIN, 0};
  EXPECT_EQ(poll(&p, 1, 0), 0);
  ASSERT_EQ(raise(SIGINT), 0);
  p.revents = 0;
  ASSERT_EQ(poll(&p, 1, 0), 1);
  EXPECT_NE(p.revents & POLLIN, 0);
  EXPECT_EQ(w.wait(nanoseconds::zero()), SIGINT);
  p.revents = 0;
  EXPECT_EQ(poll(&p, 1, 0), 0);  // taken by wait(): no longer readable
  EXPECT_EQ(w.fd(), p.fd);       // one descriptor for the waiter's life
}
