// step() and reset() must not allocate (the daemon runs them per scan). Counted with a
// replaced global operator new, armed only around the calls under test.
// GCC inlines gtest's `delete` of a `new`ed test object into our free() and misreports it.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include "pof/core/compensator.hpp"
#include "pof/core/statistics.hpp"

namespace {
std::atomic<bool> g_armed{false};
std::atomic<long> g_allocs{0};
}  // namespace

void* operator new(std::size_t n) {
  if (g_armed.load()) ++g_allocs;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

TEST(CompensatorAlloc, StepResetAndStatisticsNeverAllocate) {
  pof::core::Calibration cal;
  cal.model = pof::core::paper_coefficients();
  cal.reference_level_v = 4.0;
  pof::core::CompensatorSettings settings;
  settings.reversal_window_s = 0.1;  // the optional second window too
  pof::core::OnlineCompensator comp(cal, settings);
  pof::core::CycleStatistics stats;
  double sink = 0;
  g_armed = true;
  for (int i = 0; i < 20000; ++i) {
    const double ang = 45 + 40 * std::sin(i / 400.0);
    const auto s = comp.step(pof::core::quasi_static_voltage(cal.model, ang), 4.0);
    stats.add(i / 200.0, s, ang);
    if (i == 10000) comp.reset();
    sink += s.angle_deg;
  }
  stats.finish();
  g_armed = false;
  EXPECT_EQ(g_allocs.load(), 0);
  EXPECT_GT(stats.cycles_kept(), 0);
  EXPECT_TRUE(std::isfinite(sink));
}

TEST(CompensatorAlloc, DynamicModelStepNeverAllocates) {
  pof::core::Calibration cal;
  cal.model = pof::core::paper_coefficients();
  cal.reference_level_v = 4.0;
  pof::core::DynamicModel m;
  m.degree = 3;
  m.poly = {2.35, -0.99, 0.03, 0.02, 0, 0};
  m.n_operators = 8;
  for (int i = 0; i < 8; ++i) {
    m.threshold_deg[static_cast<std::size_t>(i)] = 0.5 * (i + 1);
    m.weight_v_per_deg[static_cast<std::size_t>(i)] = 0.001;
  }
  m.n_prony = 3;
  m.prony_tau_s = {1, 5, 30};
  m.prony_gain_v_per_deg = {-0.0005, -0.0003, -0.0001};
  m.rate_gain_s_per_rad = -1;
  m.bend_lag_s = 0.08;  // the lag inverse's window runs too
  cal.dynamic = m;
  cal.active = pof::core::ModelKind::kDynamic;
  // The per-scan inverse, the estimator, and the estimator with the longest fixed lag.
  for (const double lag_s : {-1.0, 0.0, pof::core::kMaxSmootherLag / 200.0}) {
    pof::core::CompensatorSettings settings;
    if (lag_s >= 0) {
      cal.estimator = pof::core::EstimatorNoise{0.0015, 300};
      settings.estimator_lag_s = lag_s;
    }
    pof::core::OnlineCompensator comp(cal, settings);
    ASSERT_EQ(comp.estimating(), lag_s >= 0);
    double sink = 0;
    g_armed = true;
    for (int i = 0; i < 20000; ++i) {
      const double ang = 45 + 40 * std::sin(i / 400.0);
      const auto s = comp.step(i % 5000 == 7 ? std::nan("") : m.quasi_static_v(ang), 4.0);  // and unusable scans
      if (i == 10000) comp.reset();
      sink += std::isfinite(s.angle_deg) ? s.angle_deg : 0.0;
    }
    g_armed = false;
    EXPECT_EQ(g_allocs.load(), 0) << "estimator lag " << lag_s << " s (-1: the inverse)";
    EXPECT_TRUE(std::isfinite(sink));
  }
}

// Every effect the compensator can apply from [gap] (gap_terms.hpp), on both models, through
// unusable scans and a reset: the corrector's buffers are all sized at construction.
TEST(CompensatorAlloc, GapTermsNeverAllocate) {
  pof::core::GapModel g;
  g.delay_s = 0.012;
  g.backlash_deg = 0.8;
  auto term = [](const char* effect, double theta, std::vector<double> c) {
    pof::core::GapTerm t;
    t.effect = effect;
    t.theta = theta;
    t.coefficients_v = std::move(c);
    return t;
  };
  g.terms = {term("static_nonlinearity", 0, {0.01, -0.008, 0.005, 0.004}), term("creep", 5.0, {-0.001}),
             term("viscoelastic_relaxation", 0, {-0.0005, -0.0002}), term("memory_hysteresis", 0, {0.0003, 0.0003}),
             term("rate_dependent_hysteresis", 0.2, {0.005, 0.2}), term("acceleration_dependence", 0.05, {0.002}),
             term("source_power_coupling", 0, {0.1, 0.02}), term("periodic_interference", 50, {0.003, 0.002, 0.001, 0.001}),
             term("memory_hysteresis", 10.0, {0.0002, 0.0004})};
  g.terms[2].time_constants_s = {1.5, 20};
  g.terms[3].thresholds_deg = {1, 3};
  g.terms[8].relay_centres_deg = {20, 70};
  for (const bool dynamic : {false, true}) {
    for (const double delay : {0.012, -0.02}) {
      g.delay_s = delay;
      pof::core::Calibration cal;
      cal.model = pof::core::paper_coefficients();
      cal.reference_level_v = 4.0;
      cal.gap = g;
      if (dynamic) {
        pof::core::DynamicModel m;
        m.poly = {pof::core::quasi_static_voltage(cal.model, 45), -45 / cal.model.c9, 0, 0, 0, 0};
        cal.dynamic = m;
        cal.active = pof::core::ModelKind::kDynamic;
      }
      pof::core::OnlineCompensator comp(cal);
      double sink = 0;
      g_armed = true;
      for (int i = 0; i < 20000; ++i) {
        const double ang = 45 + 40 * std::sin(i / 400.0);
        const bool bad = i % 5000 == 4999;  // an unusable scan now and then
        const auto s = comp.step(bad ? std::nan("") : pof::core::quasi_static_voltage(cal.model, ang), 4.0);
        if (i == 10000) comp.reset();
        if (!bad) sink += s.angle_deg;
      }
      g_armed = false;
      EXPECT_EQ(g_allocs.load(), 0) << (dynamic ? "dynamic" : "paper") << ", delay " << delay;
      EXPECT_TRUE(std::isfinite(sink));
    }
  }
}
