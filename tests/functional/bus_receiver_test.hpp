#pragma once
// What the bus::Receiver tests share (test_bus_receiver.cpp over memq://, test_bus_receiver_udpm.cpp
// over udpm://): a numbered angle message and a handle loop that waits on a condition.
#include <chrono>
#include <cstdint>

#include "pof/angle_t.hpp"
#include "pof/bus/receiver.hpp"

namespace pof::test {

/// An angle_t whose seq and angle say which one it is.
inline pof::angle_t numbered_angle(std::int64_t seq) {
  pof::angle_t a{};
  a.seq = seq;
  a.angle_deg = 10.0f * float(seq);
  return a;
}

/// Handles until `done()` or 5 s (a generous bound, also for loopback multicast; the condition is
/// what is awaited).
template <class Done>
void handle_until(pof::bus::Receiver& rx, Done done) {
  const auto t0 = std::chrono::steady_clock::now();
  while (!done() && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(5)) rx.handle(20);
}

}  // namespace pof::test
