#pragma once
// Waiting in a test on a condition that has no notification of its own (a counter another thread
// bumps): poll it with a deadline, so a broken build fails the test instead of hanging it.
#include <chrono>
#include <thread>

namespace pof::test {

/// Polls `done()` every `period` until it returns true (then true) or `timeout` passes (false).
template <class Done>
bool poll_until(Done done, std::chrono::milliseconds timeout = std::chrono::seconds(10),
                std::chrono::milliseconds period = std::chrono::milliseconds(1)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(period);
  }
  return true;
}

}  // namespace pof::test
