#pragma once
// The analog side of the virtual DAQs: the simulated exoskeleton knee (pof::sim::Simulator,
// docs/simulator.md) wired to the device's analog inputs the way daq.toml's default [channels]
// says a lab wires a real one:
//
//   ai0 = POF sensor photodetector, ai1 = reference fibre photodetector, ai2 = knee potentiometer;
//   every other input is grounded (0 V).
//
// The virtual devices sample it on their own scan clock: scan `index` of device session `session`
// (a session starts at each power-up/configuration: the device's scan index restarts at 0, and
// the device model calls begin_session()) is bench scan offset(session) + index, and a new session
// continues the signal where the previous one stopped (the knee does not rewind when the cable is
// pulled). Scans are generated once, one at a time, in order, on demand (the Simulator is
// sequential) and kept until forget_before(), so the device that serves a scan and the checker
// that verifies the daemon's output read the same numbers. A lookup of a scan the bench cannot
// give (forgotten, past the end of its session, a session never begun) is counted as a miss and
// reads 0 V: pof-vdaq fails a run with misses (the two sides disagree on what was sent).
//
// The scenario's trajectory loops (Scenario::loop): long runs (60-s maximum-rate tests, 10-minute
// benchmarks) never run out of signal. The simulator's own converter model is
// the "analog" signal here; the virtual device then quantises it with its own coding.
//
// Threading: not synchronised; the virtual device's mutex guards it (the device thread serves,
// the checker's LCM thread verifies).
#include <cstdint>
#include <cstdio>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "pof/sim/scenario.hpp"
#include "pof/sim/simulator.hpp"

namespace pof::vusb {

struct BenchOptions {
  std::string scenario = "session";  // built-in name or scenario file path (scenario_by_name_or_path)
  std::uint64_t seed = 1;
  double scan_rate_hz = 1000;        // the device's scan rate: the simulator's time step
  std::string truth_csv;             // write every generated scan (ground truth) here; "" = off
};

class AnalogBench {
 public:
  /// Throws pof::ConfigError / NoInputError (unknown scenario), std::runtime_error (truth file).
  explicit AnalogBench(const BenchOptions& o);
  ~AnalogBench();
  AnalogBench(const AnalogBench&) = delete;
  AnalogBench& operator=(const AnalogBench&) = delete;

  /// The device starts a new session (power-up or reconfiguration): its scan 0 is the next bench
  /// scan not yet generated. Returns the session's number (1, 2, ...).
  int begin_session();
  /// Volts on analog input `ai` at scan `index` of device session `session`; 0 V and a counted miss
  /// for a scan already forgotten, beyond the end of an earlier session or of a session never begun.
  double volts(int session, std::int64_t index, unsigned ai);
  /// Drops the scans before `index` of `session` (and every earlier session's).
  void forget_before(int session, std::int64_t index);
  [[nodiscard]] long misses() const { return misses_; }

  [[nodiscard]] std::int64_t scans_generated() const { return generated_; }
  [[nodiscard]] const std::string& scenario_name() const { return scenario_.name; }

 private:
  struct Row {
    double sensor_v, reference_v, pot_v;
  };
  void generate_through(std::int64_t bench_index);
  std::int64_t bench_index(int session, std::int64_t index);

  BenchOptions o_;
  pof::sim::Scenario scenario_;
  std::unique_ptr<pof::sim::Simulator> sim_;
  std::deque<Row> rows_;          // bench scans [base_, generated_)
  std::int64_t base_ = 0;
  std::int64_t generated_ = 0;
  std::vector<std::int64_t> session_offset_;  // bench index of scan 0 of session s at [s - 1]
  std::FILE* truth_ = nullptr;
  long misses_ = 0;
};

}  // namespace pof::vusb
