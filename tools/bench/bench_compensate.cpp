// Per-scan cost of the online compensation, against a baseline measured in the same run:
// the bare quasi-static line f5 on the normalised voltage (what an uncompensated sensor costs).
// Input: the paper-like calibration protocol from tests/support (200 Hz, USB-6008 noise and
// quantisation), replayed scan by scan; items/s = scans/s.
#include <benchmark/benchmark.h>

#include <vector>

#include "pof/testing/paper_protocol.hpp"
#include "pof/core/compensator.hpp"
#include "pof/core/dynamic_fit.hpp"
#include "pof/core/normalise.hpp"
#include "pof/core/statistics.hpp"

namespace {

const pof::testing::Generated& data() {
  static const auto g = pof::testing::paper_recording();
  return g;
}

pof::core::Calibration calibration() {
  pof::core::Calibration c;
  c.model = pof::core::paper_coefficients();
  c.reference_level_v = 4.0;
  return c;
}

// Baseline: reference guard + normalisation + f5 (no velocity, no direction, no eq. 11/12).
void BM_BaselineF5(benchmark::State& state) {
  const auto& g = data();
  const auto cal = calibration();
  pof::core::ReferenceGuard guard;
  guard.level_v = cal.reference_level_v;
  const Eigen::Index n = g.size();
  Eigen::Index i = 0;
  for (auto _ : state) {
    const auto v = pof::core::normalise(g.sensor_v(i), g.reference_v(i), guard);
    double a = pof::core::quasi_static_angle(cal.model, v.v);
    benchmark::DoNotOptimize(a);
    if (++i == n) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_BaselineF5);

// The full online path of one scan: guard, f5, causal velocity, dead-band direction, eq. (11)/(12),
// quality flags.
// step() over the recording, round and round: the loop every step benchmark times.
void run_steps(benchmark::State& state, pof::core::OnlineCompensator& comp) {
  const auto& g = data();
  const Eigen::Index n = g.size();
  Eigen::Index i = 0;
  for (auto _ : state) {
    auto s = comp.step(g.sensor_v(i), g.reference_v(i));
    benchmark::DoNotOptimize(s);
    if (++i == n) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_OnlineCompensatorStep(benchmark::State& state) {
  pof::core::OnlineCompensator comp(calibration());
  run_steps(state, comp);
}
BENCHMARK(BM_OnlineCompensatorStep);

// The same with model steps off (CompensatorSettings::model_steps): what looking for the paper
// model's start/stop/reversal steps costs per scan.
void BM_OnlineCompensatorStepNoModelSteps(benchmark::State& state) {
  pof::core::CompensatorSettings s;
  s.model_steps = false;
  pof::core::OnlineCompensator comp(calibration(), s);
  run_steps(state, comp);
}
BENCHMARK(BM_OnlineCompensatorStepNoModelSteps);

// What pof-compensatord does per scan with statistics on: step + table-3 cycle statistics.
void BM_OnlineCompensatorStepWithStatistics(benchmark::State& state) {
  const auto& g = data();
  pof::core::OnlineCompensator comp(calibration());
  pof::core::CycleStatistics stats;
  const Eigen::Index n = g.size();
  Eigen::Index i = 0;
  for (auto _ : state) {
    const auto s = comp.step(g.sensor_v(i), g.reference_v(i));
    benchmark::DoNotOptimize(stats.add(g.t_s(i), s, g.angle_ref_deg(i)));
    if (++i == n) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_OnlineCompensatorStepWithStatistics);

// The dynamic model's online inverse in place of eq. (11)/(12) (the rest of step() unchanged).
// Arg 0: the model pof calibrate fits to this recording; arg 1: the largest structure the fit
// tries (12 stop operators, 4 Prony terms, a rate factor, a 0.32 s bend lag whose inverse runs a
// 0.12 s window), the worst case per scan.
pof::core::Calibration dynamic_calibration(bool largest) {
  auto c = calibration();
  const auto& g = data();
  pof::core::DynamicModel m = pof::core::fit_dynamic(g.t_s, g.sensor_v.array() * (4.0 / g.reference_v.array()), g.angle_ref_deg).model;
  if (largest) {
    const auto r = pof::core::operator_thresholds(12, 0.5, 36);
    const auto tau = pof::core::prony_time_constants(4, 0.5, 60);
    m.n_operators = 12;
    for (std::size_t i = 0; i < 12; ++i) {
      m.threshold_deg[i] = r[i];
      m.weight_v_per_deg[i] = 0.0002;
    }
    m.n_prony = 4;
    for (std::size_t j = 0; j < 4; ++j) {
      m.prony_tau_s[j] = tau[j];
      m.prony_gain_v_per_deg[j] = -0.0001;
    }
    m.rate_gain_s_per_rad = -1;
    m.bend_lag_s = 0.32;
  }
  c.dynamic = m;
  c.active = pof::core::ModelKind::kDynamic;
  return c;
}

void BM_OnlineCompensatorStepDynamic(benchmark::State& state) {
  pof::core::OnlineCompensator comp(dynamic_calibration(state.range(0) == 1));
  run_steps(state, comp);
}
BENCHMARK(BM_OnlineCompensatorStepDynamic)->Arg(0)->Arg(1);

// The same two models with their angle estimated (angle_estimator.hpp) instead of inverted: the
// noises fit_dynamic identifies on this recording. Arg 2: the largest structure with a 10-scan
// fixed lag (the smoother's backward pass).
void BM_OnlineCompensatorStepEstimator(benchmark::State& state) {
  auto cal = dynamic_calibration(state.range(0) >= 1);
  const auto& g = data();
  cal.estimator = pof::core::fit_dynamic(g.t_s, g.sensor_v.array() * (4.0 / g.reference_v.array()), g.angle_ref_deg).estimator;
  pof::core::CompensatorSettings s;
  if (state.range(0) == 2) s.estimator_lag_s = 10 / s.scan_rate_hz;
  pof::core::OnlineCompensator comp(cal, s);
  if (!comp.estimating()) state.SkipWithError("no estimator identified");
  run_steps(state, comp);
}
BENCHMARK(BM_OnlineCompensatorStepEstimator)->Arg(0)->Arg(1)->Arg(2);

// Every effect the compensator can apply from a calibration's [gap] (gap_terms.hpp) on top of
// the paper's chain (arg 0) or the fitted dynamic model (arg 1): the notch, seven voltage terms
// (two Prony-like and three stop-operator bases among them), the delay's extrapolation and the
// play. Compare with BM_OnlineCompensatorStep and BM_OnlineCompensatorStepDynamic/0.
pof::core::GapModel every_online_term() {
  auto term = [](const char* effect, double theta, std::vector<double> c) {
    pof::core::GapTerm t;
    t.effect = effect;
    t.theta = theta;
    t.coefficients_v = std::move(c);
    return t;
  };
  pof::core::GapModel g;
  g.delay_s = 0.012;
  g.backlash_deg = 0.8;
  g.terms = {term("static_nonlinearity", 0, {0.01, -0.008, 0.005, 0.004}),
             term("creep", 5.0, {-0.001}),
             term("viscoelastic_relaxation", 0, {-0.0005, -0.0002}),
             term("memory_hysteresis", 0, {0.0003, 0.0003, 0.0003}),
             term("rate_dependent_hysteresis", 0.2, {0.005, 0.2}),
             term("acceleration_dependence", 0.05, {0.002}),
             term("source_power_coupling", 0, {0.1, 0.02}),
             term("periodic_interference", 50, {0.003, 0.002, 0.001, 0.001})};
  g.terms[2].time_constants_s = {1.5, 20};
  g.terms[3].thresholds_deg = {1, 3, 6};
  return g;
}

void BM_OnlineCompensatorStepGap(benchmark::State& state) {
  auto cal = state.range(0) == 1 ? dynamic_calibration(false) : calibration();
  cal.gap = every_online_term();
  pof::core::OnlineCompensator comp(cal);
  run_steps(state, comp);
}
BENCHMARK(BM_OnlineCompensatorStepGap)->Arg(0)->Arg(1);

}  // namespace

BENCHMARK_MAIN();
