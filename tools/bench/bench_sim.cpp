// bench_sim: cost of simulating data (target: "one hour at 200 Hz takes well under a second per
// minute of data"). Each case simulates one hour of a scenario in a loop (the trajectory restarts)
// and reports seconds of CPU (this thread) per minute of data and ns per scan. The baseline, measured in the same
// run, is the knee trajectory alone (Trajectory::step, no sensor, light or DAQ): the difference is
// what the physics of the effects costs. The 16 kS/s case is the virtual USB-6009's load
// (48 kS/s aggregate over 3 channels).
//
//   build/bin/bench_sim --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <time.h>

#include <vector>

#include "pof/sim/scenario.hpp"
#include "pof/sim/simulator.hpp"
#include "pof/sim/trajectory.hpp"

namespace {

constexpr double kHour = 3600;

// The machine is shared by several builds: the figures use this thread's CPU time, not wall time.
double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

pof::sim::Scenario looping(const char* name, double seconds) {
  pof::sim::Scenario s = pof::sim::builtin_scenario(name);
  s.loop = true;
  s.duration_s = seconds;
  return s;
}

void report(benchmark::State& st, double elapsed_s, double data_s, double scans) {
  st.counters["s_per_data_min"] = benchmark::Counter(elapsed_s / (data_s / 60.0), benchmark::Counter::kAvgIterations);
  st.counters["ns_per_scan"] = benchmark::Counter(elapsed_s * 1e9 / scans, benchmark::Counter::kAvgIterations);
}

// Baseline: the commanded trajectory and the knee's limited motion only.
void BM_TrajectoryOnly_Hour200Hz(benchmark::State& st) {
  const auto s = looping("realistic", kHour);
  double elapsed = 0;
  const auto n = static_cast<std::int64_t>(kHour * 200);
  for (auto _ : st) {
    const double t0 = thread_cpu_s();
    pof::sim::Trajectory traj(s, 1, 1.0 / 200);
    double acc = 0;
    for (std::int64_t k = 0; k < n; ++k) acc += traj.step().angle_deg;
    benchmark::DoNotOptimize(acc);
    elapsed += thread_cpu_s() - t0;
  }
  report(st, elapsed, kHour, static_cast<double>(n));
}

void simulate(benchmark::State& st, const char* name, double seconds, double rate) {
  const auto s = looping(name, seconds);
  std::vector<pof::sim::Scan> buf(1024);
  double elapsed = 0, scans = 0;
  for (auto _ : st) {
    const double t0 = thread_cpu_s();
    pof::sim::Simulator sim(s, 1, rate);
    std::size_t n = 0, total = 0;
    while ((n = sim.next(buf)) > 0) total += n;
    benchmark::DoNotOptimize(buf.data());
    elapsed += thread_cpu_s() - t0;
    scans = static_cast<double>(total);
  }
  report(st, elapsed, seconds, scans);
}

void BM_Simulate_Paper_Hour200Hz(benchmark::State& st) { simulate(st, "paper", kHour, 200); }
void BM_Simulate_Realistic_Hour200Hz(benchmark::State& st) { simulate(st, "realistic", kHour, 200); }
void BM_Simulate_Realistic_Minute16kHz(benchmark::State& st) { simulate(st, "realistic", 60, 16000); }

}  // namespace

BENCHMARK(BM_TrajectoryOnly_Hour200Hz)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Simulate_Paper_Hour200Hz)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Simulate_Realistic_Hour200Hz)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Simulate_Realistic_Minute16kHz)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
