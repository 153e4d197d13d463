// The streaming contract of the simulator: next() must not allocate, because the DAQ
// virtual devices call it on their real-time path at up to 48 kS/s. Global operator new is counted.
// GCC 12 sees the replaced operator delete (std::free) inlined into std::allocator and warns of a
// new/free mismatch; the replacement new below does use malloc, so the pair is consistent.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <string>
#include <vector>

#include "pof/sim/simulator.hpp"

namespace {
std::atomic<long> g_allocations{0};
}

void* operator new(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

TEST(SimStreaming, TheCounterSeesAllocations) {
  const long before = g_allocations.load();
  auto* v = new std::vector<double>(100);
  EXPECT_GE(g_allocations.load() - before, 2);
  delete v;
}

TEST(SimStreaming, NextDoesNotAllocate) {
  for (const char* name : {"paper", "realistic", "fibre_calibration", "heldout_random", "maxwell_slip", "preisach"}) {
    const bool slip = std::string(name) == "maxwell_slip", preisach = std::string(name) == "preisach";
    pof::sim::Scenario s = pof::sim::builtin_scenario(slip ? "heldout_gait" : preisach ? "heldout_fast_gait" : name);
    s.loop = true;
    s.daq.time_delay.enabled = true;  // every optional state in use
    s.sensor.rate_dependent_hysteresis.enabled = true;
    s.sensor.viscoelastic_lag.enabled = true;
    if (slip) s.sensor.memory_hysteresis.family = pof::sim::MemoryHysteresisFamily::kMaxwellSlip;
    if (preisach) {  // the relay grid, the power-law bank and the softening's travel
      s.sensor.memory_hysteresis.family = pof::sim::MemoryHysteresisFamily::kPreisach;
      s.sensor.power_law_relaxation.enabled = true;
      s.sensor.cyclic_softening.enabled = true;
    }
    pof::sim::Simulator sim(s, 1, 16000);
    std::vector<pof::sim::Scan> buf(512);
    std::vector<pof::sim::EffectTrace> tr(512);
    const long before = g_allocations.load();
    std::size_t n = 0;
    for (int i = 0; i < 400; ++i) n += sim.next(buf, tr);  // 12.8 s of data at 16 kS/s
    EXPECT_EQ(g_allocations.load() - before, 0) << name;
    EXPECT_EQ(n, 400u * 512u);
  }
}
