// pof_sim: the viscoelastic fibre effects (memory hysteresis: Bouc-Wen, Maxwell-slip and Preisach,
// the speed factor, the viscoelastic lag, power-law relaxation, cyclic softening), the
// random_moves trajectory, gait at exoskeleton speeds and
// the fibre / held-out scenarios (docs/simulator.md). As in test_sim.cpp every check runs the
// simulator without noise, with a 24-bit converter and without multiplexing, and reads the effect
// contributions from EffectTrace.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

#include "pof/core/model.hpp"
#include "pof/base/errors.hpp"
#include "pof/sim/scenario.hpp"
#include "pof/sim/simulator.hpp"
#include "pof/sim/trajectory.hpp"

namespace {

using pof::sim::EffectTrace;
using pof::sim::MemoryHysteresisFamily;
using pof::sim::Scan;
using pof::sim::Scenario;
using pof::sim::Segment;
using pof::sim::SegmentKind;

constexpr double kDegPerRad = 180.0 / std::numbers::pi;

struct SimRun {
  std::vector<Scan> scans;
  std::vector<EffectTrace> trace;
};

SimRun run(const Scenario& s, std::uint64_t seed = 1, double rate = 0) {
  pof::sim::Simulator sim(s, seed, rate);
  SimRun r;
  std::vector<Scan> buf(1000);
  std::vector<EffectTrace> tb(1000);
  while (const std::size_t n = sim.next(buf, tb)) {
    r.scans.insert(r.scans.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
    r.trace.insert(r.trace.end(), tb.begin(), tb.begin() + static_cast<std::ptrdiff_t>(n));
  }
  return r;
}

// A quiet rig (no noise, 24 bits, no multiplexing) with the paper's step hysteresis off, so the
// sensor is the quasi-static line plus whatever the test switches on.
Scenario quiet() {
  Scenario s = pof::sim::builtin_scenario("paper");
  s.daq.noise.enabled = false;
  s.daq.bits = 24;
  s.daq.multiplexed = false;
  s.sensor.hysteresis.enabled = false;
  s.trajectory.clear();
  return s;
}

Segment go(double angle_deg, double velocity_rad_s, double hold_s) {
  Segment g;
  g.kind = SegmentKind::kHold;
  g.has_angle = true;
  g.angle_deg = angle_deg;
  g.move_velocity_rad_s = velocity_rad_s;
  g.duration_s = hold_s;
  return g;
}

Segment cycles(std::vector<double> velocities, double min_deg, double max_deg, double pause_s = 2) {
  Segment g;
  g.kind = SegmentKind::kCycles;
  g.velocities_rad_s = std::move(velocities);
  g.min_deg = min_deg;
  g.max_deg = max_deg;
  g.pause_s = pause_s;
  return g;
}

Scenario with_memory(MemoryHysteresisFamily family, double rate_sensitivity = 0) {
  Scenario s = quiet();
  auto& mh = s.sensor.memory_hysteresis;
  mh.enabled = true;
  mh.family = family;
  mh.amplitude_v = 0.025;
  mh.width_deg = 12;
  mh.thresholds_deg = {2, 5, 10};
  mh.weights = {1, 2, 1};
  mh.rate_sensitivity_s_per_rad = rate_sensitivity;
  return s;
}

// [begin, end) of the first hold (velocity exactly 0) at `angle` that starts at or after `from`.
std::pair<std::size_t, std::size_t> hold_at(const SimRun& r, double angle, std::size_t from = 0) {
  std::size_t i = from;
  while (i < r.scans.size() && !(r.trace[i].velocity_rad_s == 0 && std::abs(r.scans[i].angle_true_deg - angle) < 1e-9)) ++i;
  std::size_t j = i;
  while (j < r.scans.size() && r.trace[j].velocity_rad_s == 0 && std::abs(r.scans[j].angle_true_deg - angle) < 1e-9) ++j;
  return {i, j};
}

// Value of trace field `get` where a stroke at cruise velocity `w` [rad/s, signed] crosses `angle`
// (the first such crossing at or after scan `from`).
template <class Get>
double at_crossing(const SimRun& r, double w, double angle, Get get, std::size_t from = 1) {
  for (std::size_t i = std::max<std::size_t>(from, 1); i < r.scans.size(); ++i) {
    if (std::abs(r.trace[i].velocity_rad_s - w) > 1e-9 || std::abs(r.trace[i - 1].velocity_rad_s - w) > 1e-9) continue;
    const double a0 = r.scans[i - 1].angle_true_deg, a1 = r.scans[i].angle_true_deg;
    if ((a0 - angle) * (a1 - angle) > 0 || a0 == a1) continue;
    const double f = (angle - a0) / (a1 - a0);
    return (1 - f) * get(r.trace[i - 1]) + f * get(r.trace[i]);
  }
  ADD_FAILURE() << "no crossing of " << angle << " deg at " << w << " rad/s";
  return NAN;
}

std::string config_error(const std::string& toml) {
  try {
    (void)pof::sim::parse_scenario(toml, "t.toml");
  } catch (const pof::ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

const std::string kMinimal = "schema_version = 1\n[[trajectory]]\nkind = \"hold\"\nduration_s = 1\n";

// ------------------------------------------------------------------------------ memory hysteresis
TEST(SimMemoryHysteresis, PersistsThroughHoldsAndHasTheOppositeSignAfterExtension) {
  for (auto family : {MemoryHysteresisFamily::kBoucWen, MemoryHysteresisFamily::kMaxwellSlip}) {
    Scenario s = with_memory(family);
    // Flexion 0 -> 60 deg, 10 s hold; on to 90; extension back to 60, 10 s hold.
    s.trajectory = {go(0, 0.1, 1), go(60, 0.1, 10), go(90, 0.1, 1), go(60, 0.1, 10)};
    const SimRun r = run(s);
    const auto [b1, e1] = hold_at(r, 60);
    const auto [b2, e2] = hold_at(r, 60, e1 + 1);
    ASSERT_GE(e1 - b1, 1999u);
    ASSERT_GE(e2 - b2, 1999u);
    const double after_flexion = r.trace[b1].memory_hysteresis_v;
    const double after_extension = r.trace[b2].memory_hysteresis_v;
    // Maxwell-slip saturates exactly beyond its largest threshold, Bouc-Wen (n = 1) exponentially:
    // 30 deg after a reversal with width 12 deg it is within e^-9 of saturation.
    const double tol = family == MemoryHysteresisFamily::kMaxwellSlip ? 1e-12 : 0.025 * 2e-4;
    EXPECT_NEAR(after_flexion, 0.025, tol) << "saturated: 60 deg of flexion from the demagnetised state";
    EXPECT_NEAR(after_extension, -0.025, tol) << "30 deg of extension: beyond every threshold, 2.5 widths";
    for (std::size_t i = b1; i < e1; ++i) ASSERT_EQ(r.trace[i].memory_hysteresis_v, after_flexion) << "no decay in the hold";
    for (std::size_t i = b2; i < e2; ++i) ASSERT_EQ(r.trace[i].memory_hysteresis_v, after_extension);
    // The sensor voltage at the same angle differs by the loop height (flexion branch above).
    EXPECT_NEAR(r.scans[b1 + 100].sensor_v - r.scans[b2 + 100].sensor_v, 0.05, 2 * tol + 1e-6);
  }
  // With a speed factor the stored state is unchanged; the output settles to the rate-independent
  // value with the filter's time constant (0.2 s) and then stays: it never decays in the hold.
  Scenario s = with_memory(MemoryHysteresisFamily::kBoucWen, -1.5);
  s.trajectory = {go(0, 0.3, 1), go(60, 0.3, 10)};
  const SimRun r = run(s);
  const auto [b, e] = hold_at(r, 60);
  for (std::size_t i = b + 1; i < e; ++i) ASSERT_GE(r.trace[i].memory_hysteresis_v, r.trace[i - 1].memory_hysteresis_v);
  EXPECT_LT(r.trace[b].memory_hysteresis_v, 0.025 * std::exp(-1.5 * 0.2));
  EXPECT_NEAR(r.trace[e - 1].memory_hysteresis_v, 0.025, 1e-9);
}

TEST(SimMemoryHysteresis, BothFamiliesSaturateAtTheAmplitudeAndMinorLoopsStayInside) {
  for (auto family : {MemoryHysteresisFamily::kBoucWen, MemoryHysteresisFamily::kMaxwellSlip}) {
    Scenario s = with_memory(family);
    // Major loop 0 -> 90 -> 0 -> 90, then down to 20 and a partial reversal up to 30 and 25.
    s.trajectory = {go(90, 0.2, 1), go(0, 0.2, 1), go(90, 0.2, 1), go(20, 0.2, 1), go(30, 0.2, 1), go(25, 0.2, 1)};
    const SimRun r = run(s);
    double lo = 1, hi = -1;
    for (const auto& t : r.trace) lo = std::min(lo, t.memory_hysteresis_v), hi = std::max(hi, t.memory_hysteresis_v);
    EXPECT_NEAR(hi, 0.025, 1e-9);
    EXPECT_NEAR(lo, -0.025, 1e-9);
    EXPECT_LE(hi, 0.025);
    EXPECT_GE(lo, -0.025);
    // Major branches at 30 deg: ascending from 0 (saturated +), descending from 90 (saturated -).
    const double up = at_crossing(r, 0.2, 30, [](const EffectTrace& t) { return t.memory_hysteresis_v; });
    const double down = at_crossing(r, -0.2, 30, [](const EffectTrace& t) { return t.memory_hysteresis_v; });
    const double tol = family == MemoryHysteresisFamily::kMaxwellSlip ? 1e-12 : 0.025 * 2e-4;
    EXPECT_NEAR(up, 0.025, tol);
    EXPECT_NEAR(down, -0.025, tol);
    // Minor loop: reversed at 20 deg, 10 deg later the state is strictly inside the major loop,
    // and going back down 5 deg it moves back towards the descending branch, still inside.
    const auto [b30, e30] = hold_at(r, 30);
    const auto [b25, e25] = hold_at(r, 25, e30);
    const double m30 = r.trace[b30].memory_hysteresis_v, m25 = r.trace[b25].memory_hysteresis_v;
    EXPECT_GT(m30, down + 0.1 * 0.025) << static_cast<int>(family);
    EXPECT_LT(m30, up - 0.05 * 0.025) << static_cast<int>(family);
    EXPECT_LT(m25, m30);
    EXPECT_GT(m25, down);
  }
  // Maxwell-slip is exact: thresholds 2, 5, 10 deg with weights 1:2:1 after a 10-deg reversal from
  // negative saturation: elements 1 and 2 saturated +, element 3 at 0 -> (1 + 2 + 0) / 4.
  Scenario s = with_memory(MemoryHysteresisFamily::kMaxwellSlip);
  s.trajectory = {go(90, 0.2, 1), go(20, 0.2, 1), go(30, 0.2, 1)};
  const SimRun r = run(s);
  EXPECT_NEAR(r.trace.back().memory_hysteresis_v, 0.025 * 0.75, 1e-12);
  EXPECT_NEAR(r.trace.back().memory_state, 0.75, 1e-12);
}

TEST(SimMemoryHysteresis, BoucWenWidthIsTheSaturationAngle) {
  // width_deg: from one saturation to 95 % of the other, for several shapes and beta fractions,
  // and at a coarse scan rate (sub-steps) the same as at a fine one.
  struct Case { double width, shape, beta; };
  for (const Case c : {Case{12, 1, 0.5}, Case{6, 2, 0.5}, Case{20, 1, 0.8}, Case{10, 1.5, 0.25}}) {
    for (double rate : {200.0, 10.0}) {
      Scenario s = with_memory(MemoryHysteresisFamily::kBoucWen);
      s.sensor.memory_hysteresis.width_deg = c.width;
      s.sensor.memory_hysteresis.shape = c.shape;
      s.sensor.memory_hysteresis.beta_fraction = c.beta;
      // From 60 deg down to -10 (saturated at -1), then width_deg of flexion.
      s.knee.start_deg = 60;
      s.trajectory = {go(-10, 0.3, 0.5), go(-10 + c.width, 0.3, 0.5)};
      const SimRun r = run(s, 1, rate);
      const auto [b, e] = hold_at(r, -10 + c.width);
      ASSERT_LT(b, r.trace.size());
      EXPECT_NEAR(r.trace[b].memory_state, 0.95, rate == 200 ? 1e-4 : 2e-3) << c.width << " " << c.shape << " " << c.beta << " @" << rate;
    }
  }
}

TEST(SimMemoryHysteresis, SpeedFactorNarrowsOrWidensTheLoop) {
  auto loop_at_45 = [](double k, double w) {
    Scenario s = with_memory(MemoryHysteresisFamily::kBoucWen, k);
    s.trajectory = {cycles({w}, 0, 90)};
    const SimRun r = run(s);
    auto mem = [](const EffectTrace& t) { return t.memory_hysteresis_v; };
    return at_crossing(r, w, 45, mem) - at_crossing(r, -w, 45, mem);
  };
  for (double k : {-1.5, 0.0, 1.5}) {
    const double slow = loop_at_45(k, 0.02), fast = loop_at_45(k, 0.4);
    // Saturated branches: the loop is 2 A exp(k w) (the filtered speed has settled at 45 deg to
    // within e^-9 of w).
    EXPECT_NEAR(slow, 0.05 * std::exp(k * 0.02), 1e-5 * 0.05) << k;
    EXPECT_NEAR(fast, 0.05 * std::exp(k * 0.4), 1e-4 * 0.05) << k;
    if (k < 0) {
      EXPECT_LT(fast, slow);
    } else if (k > 0) {
      EXPECT_GT(fast, slow);
    }
  }
}

TEST(SimMemoryHysteresis, NegativeAmplitudePutsTheExtensionBranchAbove) {
  Scenario s = with_memory(MemoryHysteresisFamily::kBoucWen);
  s.sensor.memory_hysteresis.amplitude_v = -0.02;
  s.trajectory = {cycles({0.1}, 0, 90)};
  const SimRun r = run(s);
  auto v = [](const EffectTrace& t) { return t.normalised_v; };
  EXPECT_NEAR(at_crossing(r, 0.1, 45, v) - at_crossing(r, -0.1, 45, v), -0.04, 1e-6);
}


// ------------------------------------------------------------------------------ Preisach relays
// The default density (centre 45 +- 12 deg, half-width 15 +- 6 deg) with amplitude 0.025 V.
Scenario with_preisach() {
  Scenario s = with_memory(MemoryHysteresisFamily::kPreisach);
  auto& mh = s.sensor.memory_hysteresis;
  mh.centre_deg = 45;
  mh.centre_spread_deg = 12;
  mh.half_width_deg = 15;
  mh.half_width_spread_deg = 6;
  return s;
}

double memory_v(const EffectTrace& t) { return t.memory_hysteresis_v; }

TEST(SimPreisach, BoundedByTheAmplitudeAndSaturatedBeyondEveryRelay) {
  // A narrow density: every alpha below 80 deg, every beta above 10 deg (centres 45 +- 15, half-
  // widths up to 19). Starting at 0 every relay is down (y = +1); 90 deg switches every one up.
  Scenario s = with_preisach();
  s.sensor.memory_hysteresis.centre_spread_deg = 5;
  s.sensor.memory_hysteresis.half_width_deg = 10;
  s.sensor.memory_hysteresis.half_width_spread_deg = 3;
  s.trajectory = {go(0, 0.2, 1), go(90, 0.2, 1), go(0, 0.2, 1), go(50, 0.2, 1), go(30, 0.2, 1), go(70, 0.2, 1),
                  go(40, 0.2, 1), go(85, 0.2, 1), go(20, 0.2, 1)};
  const SimRun r = run(s);
  EXPECT_NEAR(r.trace.front().memory_hysteresis_v, 0.025, 1e-12) << "demagnetised at 0 deg: every centre is above";
  EXPECT_NEAR(r.trace[hold_at(r, 90).first].memory_hysteresis_v, -0.025, 1e-12);
  EXPECT_NEAR(r.trace[hold_at(r, 0, hold_at(r, 90).second).first].memory_hysteresis_v, 0.025, 1e-12);
  for (const Scenario& sc : {s, with_preisach()}) {
    Scenario t = sc;
    t.trajectory = s.trajectory;
    const SimRun q = run(t);
    for (const auto& x : q.trace) {
      ASSERT_LE(std::abs(x.memory_hysteresis_v), 0.025);
      ASSERT_LE(std::abs(x.memory_state), 1.0);
    }
  }
}

TEST(SimPreisach, ReturnPointMemoryAndWipingOut) {
  // Return-point memory: back at a reversal point the relays are as they were, so a minor loop
  // closes bit for bit, and it is open in between (the ascending branch lies above).
  Scenario s = with_preisach();
  s.trajectory = {go(90, 0.2, 1), go(20, 0.2, 1), go(60, 0.2, 1), go(20, 0.2, 1), go(60, 0.2, 1)};
  const SimRun r = run(s);
  const auto h20a = hold_at(r, 20), h60a = hold_at(r, 60, h20a.second);
  const auto h20b = hold_at(r, 20, h60a.second), h60b = hold_at(r, 60, h20b.second);
  ASSERT_LT(h60b.first, r.trace.size());
  EXPECT_EQ(r.trace[h20a.first].memory_hysteresis_v, r.trace[h20b.first].memory_hysteresis_v);
  EXPECT_EQ(r.trace[h60a.first].memory_hysteresis_v, r.trace[h60b.first].memory_hysteresis_v);
  const double up = at_crossing(r, 0.2, 40, memory_v, h20a.second), down = at_crossing(r, -0.2, 40, memory_v, h60a.second);
  EXPECT_GT(up - down, 0.05 * 0.025);
  // Wiping-out: the excursion to 80 deg erases the 70/40 reversal pair inside it.
  Scenario a = with_preisach(), b = with_preisach();
  a.trajectory = {go(90, 0.2, 1), go(20, 0.2, 1), go(70, 0.2, 1), go(40, 0.2, 1), go(80, 0.2, 1), go(50, 0.2, 1)};
  b.trajectory = {go(90, 0.2, 1), go(20, 0.2, 1), go(80, 0.2, 1), go(50, 0.2, 1)};
  const SimRun ra = run(a), rb = run(b);
  EXPECT_EQ(ra.trace.back().memory_hysteresis_v, rb.trace.back().memory_hysteresis_v);
  // Without the excursion to 80 the 40-deg reversal is remembered: 50 deg is reached differently.
  Scenario c = with_preisach();
  c.trajectory = {go(90, 0.2, 1), go(20, 0.2, 1), go(70, 0.2, 1), go(40, 0.2, 1), go(50, 0.2, 1)};
  EXPECT_GT(std::abs(run(c).trace.back().memory_hysteresis_v - rb.trace.back().memory_hysteresis_v), 0.05 * 0.025);
}

TEST(SimPreisach, MajorLoopFollowsTheDensity) {
  // 0 -> 90 -> 0 from the demagnetised state at 0 (every relay down): at the centre u0 the loop
  // in y is 2 (P(beta < u0) - P(alpha < u0)) = 2 erf(v0 / (sqrt(2) s)), s^2 = s_u^2 + s_v^2, for the
  // continuous density (alpha = u + v, beta = u - v); the 400-relay grid (each axis cut at 3
  // spreads, v at 0) gives it within 1.5 % (0.5-0.9 % measured).
  for (const double spread : {4.0, 8.0, 12.0}) {
    Scenario s = with_preisach();
    s.sensor.memory_hysteresis.centre_spread_deg = spread;
    s.trajectory = {go(90, 0.2, 1), go(0, 0.2, 1)};
    const SimRun r = run(s);
    const double loop = (at_crossing(r, 0.2, 45, memory_v) - at_crossing(r, -0.2, 45, memory_v)) / 0.025;
    const double want = 2 * std::erf(15 / (std::sqrt(2.0) * std::hypot(spread, 6.0)));
    EXPECT_NEAR(loop, want, 0.015 * want) << spread;
    std::printf("preisach: major loop at 45 deg, centre spread %g deg: %.4f (continuous density %.4f)\n", spread, loop, want);
  }
}

TEST(SimPreisach, MinorLoopsDependOnWhereTheySitUnlikeStopOperators) {
  // A sum of stop operators (maxwell_slip, and the compensator's model) is translation invariant:
  // a 20-deg minor loop opens the same at 15 deg as at 45 deg. The Preisach density with a finite
  // centre spread is not: the loop centred on the density is much wider.
  auto opening = [](MemoryHysteresisFamily family, double lo, double hi) {
    Scenario s = family == MemoryHysteresisFamily::kPreisach ? with_preisach() : with_memory(family);
    s.trajectory = {go(90, 0.2, 1), go(0, 0.2, 1), go(hi, 0.2, 1), go(lo, 0.2, 1), go(hi, 0.2, 1), go(lo, 0.2, 1)};
    const SimRun r = run(s);
    const auto h1 = hold_at(r, lo, hold_at(r, hi, hold_at(r, 0).second).second);  // the first minor reversal at lo
    const auto h2 = hold_at(r, hi, h1.second);
    return at_crossing(r, 0.2, 0.5 * (lo + hi), memory_v, h1.second) - at_crossing(r, -0.2, 0.5 * (lo + hi), memory_v, h2.second);
  };
  const double slip_low = opening(MemoryHysteresisFamily::kMaxwellSlip, 5, 25);
  const double slip_mid = opening(MemoryHysteresisFamily::kMaxwellSlip, 35, 55);
  EXPECT_NEAR(slip_low, slip_mid, 1e-12);
  EXPECT_GT(slip_low, 0.01);
  const double low = opening(MemoryHysteresisFamily::kPreisach, 5, 25);
  const double mid = opening(MemoryHysteresisFamily::kPreisach, 35, 55);
  EXPECT_GT(low, 0);
  EXPECT_GT(mid, 3 * low);
  std::printf("minor loops of 20 deg: preisach %.5f V at 5-25 deg, %.5f V at 35-55 deg (%.1fx); maxwell_slip %.5f V at both\n",
              low, mid, mid / low, slip_mid);
}

// ------------------------------------------------------------------------------ viscoelastic lag
TEST(SimViscoelasticLag, LagsARampByTauOmegaAndConvergesInAHold) {
  Scenario s = quiet();
  s.sensor.viscoelastic_lag.enabled = true;
  s.sensor.viscoelastic_lag.tau_s = 0.3;
  s.trajectory = {go(90, 0.2, 5)};
  const SimRun r = run(s);
  const double want = 0.3 * 0.2 * kDegPerRad;  // tau omega = 3.44 deg
  std::size_t cruise = 0;
  for (std::size_t i = 0; i < r.scans.size(); ++i) {
    // In the cruise, more than 5 tau after it began (the first 0.1 s accelerate at 2 rad/s^2).
    if (r.trace[i].velocity_rad_s == 0.2 && r.scans[i].t_s > 0.1 + 5 * 0.3 && r.scans[i].angle_true_deg < 85) {
      ASSERT_NEAR(r.trace[i].lag_deg, want, 0.01 * want) << r.scans[i].t_s;
      ++cruise;
    }
  }
  EXPECT_GT(cruise, 1000u);
  // The hold: the lag decays as exp(-t / tau) and the voltage converges to the quasi-static line.
  const auto [b, e] = hold_at(r, 90);
  ASSERT_GE(e - b, 999u);
  const double l0 = r.trace[b + 10].lag_deg, l1 = r.trace[b + 10 + 60].lag_deg;  // 0.3 s later
  EXPECT_NEAR(l1 / l0, std::exp(-1.0), 1e-6);
  EXPECT_LT(std::abs(r.trace[e - 1].lag_deg), 1e-6);
  const double line90 = pof::core::quasi_static_voltage(s.sensor.model, 90);
  EXPECT_NEAR(r.scans[e - 1].sensor_v, line90, 2e-6);
  // While it lags the fibre reads a smaller angle (a higher voltage); the potentiometer does not lag.
  const std::size_t mid = b / 2;
  EXPECT_NEAR(r.trace[mid].viscoelastic_lag_v, 0.0219 * r.trace[mid].lag_deg, 0.0005);
  for (std::size_t i = 0; i < r.scans.size(); i += 13) ASSERT_NEAR(r.scans[i].angle_ref_deg, r.scans[i].angle_true_deg, 1e-5);
}

TEST(SimViscoelasticLag, LoopWidensWithSpeedAndAppliesToEveryFibreTerm) {
  Scenario s = quiet();
  s.sensor.viscoelastic_lag.enabled = true;
  s.sensor.viscoelastic_lag.tau_s = 0.1;
  s.trajectory = {cycles({0.05, 0.4}, 0, 90)};
  const SimRun r = run(s);
  auto v = [](const EffectTrace& t) { return t.normalised_v; };
  const double slow = at_crossing(r, 0.05, 45, v) - at_crossing(r, -0.05, 45, v);
  const double fast = at_crossing(r, 0.4, 45, v) - at_crossing(r, -0.4, 45, v);
  EXPECT_NEAR(slow, 2 * 0.0219 * 0.1 * 0.05 * kDegPerRad, 2e-4);
  EXPECT_NEAR(fast, 2 * 0.0219 * 0.1 * 0.4 * kDegPerRad, 2e-4);
  // The trace decomposes the voltage: every contribution sums to normalised_v.
  Scenario all = s;
  all.sensor.hysteresis.enabled = true;
  all.sensor.static_nonlinearity.enabled = true;
  all.sensor.creep.enabled = true;
  all.sensor.memory_hysteresis.enabled = true;
  all.sensor.memory_hysteresis.rate_sensitivity_s_per_rad = -1;
  all.sensor.acceleration_dependence.enabled = true;
  for (const bool newer : {false, true}) {
    // ... and with the power-law relaxation, the cyclic softening and the Preisach family.
    if (newer) {
      all.sensor.memory_hysteresis.family = MemoryHysteresisFamily::kPreisach;
      all.sensor.power_law_relaxation.enabled = true;
      all.sensor.cyclic_softening.enabled = true;
      all.sensor.cyclic_softening.loop_depth = 0.2;
    }
    const SimRun a = run(all);
    for (const auto& t : a.trace) {
      const double sum = t.quasi_static_v + t.viscoelastic_lag_v + t.hysteresis_v + t.rate_dependent_hysteresis_v + t.creep_v +
                         t.acceleration_v + t.drift_v + t.memory_hysteresis_v + t.power_law_relaxation_v + t.cyclic_softening_v;
      ASSERT_NEAR(sum, t.normalised_v, 1e-12);
      if (!newer) {
        ASSERT_EQ(t.power_law_relaxation_v + t.cyclic_softening_v + t.travel_deg, 0.0);
      }
    }
    if (newer) {
      EXPECT_GT(a.trace.back().travel_deg, 300.0);
      EXPECT_NE(a.trace.back().power_law_relaxation_v, 0.0);
    }
  }
}


// ------------------------------------------------------------------------------ power-law relaxation
TEST(SimPowerLawRelaxation, AStepRelaxesAsTToTheMinusN) {
  for (const double n : {0.2, 0.5, 0.8}) {
    Scenario s = quiet();
    s.knee.max_velocity_rad_s = 4;
    s.knee.max_acceleration_rad_s2 = 200;
    s.knee.start_deg = 30;
    auto& p = s.sensor.power_law_relaxation;
    p.enabled = true;
    p.gain_v_per_deg = -0.0003;
    p.exponent = n;
    p.min_time_s = 0.1;
    p.max_time_s = 300;
    s.trajectory = {go(40, 3.0, 120)};  // a 10-deg bend in ~0.08 s, then a 2-min hold
    const SimRun r = run(s);
    // The bend's centroid in time (each scan's increment ramps over the scan before it).
    double moment = 0, bend = 0;
    for (std::size_t i = 1; i < r.scans.size(); ++i) {
      const double d = r.scans[i].angle_true_deg - r.scans[i - 1].angle_true_deg;
      moment += (r.scans[i].t_s - 0.0025) * d;
      bend += d;
    }
    ASSERT_NEAR(bend, 10, 1e-9);
    const double t0 = moment / bend;
    // Log-log fit over 1-100 s after the bend, at 41 log-spaced times.
    std::vector<double> x, y;
    for (int k = 0; k <= 40; ++k) {
      const double t = t0 + std::pow(10.0, k / 20.0);
      const auto i = static_cast<std::size_t>(std::llround(t * 200));
      ASSERT_LT(i, r.scans.size());
      ASSERT_EQ(r.trace[i].velocity_rad_s, 0.0);
      x.push_back(std::log(r.scans[i].t_s - t0));
      y.push_back(std::log(-r.trace[i].power_law_relaxation_v));
    }
    double mx = 0, my = 0;
    const auto m = static_cast<double>(x.size());
    for (std::size_t k = 0; k < x.size(); ++k) mx += x[k] / m, my += y[k] / m;
    double sxy = 0, sxx = 0;
    for (std::size_t k = 0; k < x.size(); ++k) sxy += (x[k] - mx) * (y[k] - my), sxx += (x[k] - mx) * (x[k] - mx);
    const double slope = sxy / sxx, icpt = my - slope * mx;
    double worst = 0;
    for (std::size_t k = 0; k < x.size(); ++k) worst = std::max(worst, std::abs(y[k] - (icpt + slope * x[k])));
    EXPECT_NEAR(slope, -n, 0.01) << n;
    EXPECT_LT(worst, 0.01) << n << ": the points lie on the power law within 1 %";
    // The level: g * bend * t^-n at t = 10 s.
    const auto i10 = static_cast<std::size_t>(std::llround((t0 + 10) * 200));
    const double want10 = -0.0003 * 10 * std::pow(r.scans[i10].t_s - t0, -n);
    EXPECT_NEAR(r.trace[i10].power_law_relaxation_v / want10, 1.0, 0.015) << n;
    std::printf("power law n = %.1f: log-log slope %.4f over 1-100 s, worst residual %.2e, level at 10 s %.4f of g d t^-n\n", n, slope,
                worst, r.trace[i10].power_law_relaxation_v / want10);
  }
}

// ------------------------------------------------------------------------------ cyclic softening
TEST(SimCyclicSoftening, SensitivityFallsByTheStatedAmountAfterTheStatedTravel) {
  Scenario s = quiet();
  auto& c = s.sensor.cyclic_softening;
  c.enabled = true;
  c.depth = 0.1;
  c.travel_scale_deg = 1000;
  // Holds at 30 and 60 deg (travel 30, 60), back to 0 (120), four 0-90-0 cycles (840), then
  // 80 (920), 40 (960) and 80 again: a hold after exactly L0 = 1000 deg of travel.
  s.trajectory = {go(30, 0.3, 1), go(60, 0.3, 1), go(0, 0.3, 0.5), cycles({0.4, 0.4, 0.4, 0.4}, 0, 90, 0.5),
                  go(80, 0.3, 0.5), go(40, 0.3, 0.5), go(80, 0.3, 1)};
  const SimRun r = run(s);
  // The travel is the sum of |d theta| of the fibre; the trace's contribution adds up.
  double travel = 0;
  for (std::size_t i = 1; i < r.scans.size(); ++i) {
    travel += std::abs(r.scans[i].angle_true_deg - r.scans[i - 1].angle_true_deg);
    ASSERT_NEAR(r.trace[i].travel_deg, travel, 1e-9);
    ASSERT_NEAR(r.trace[i].quasi_static_v + r.trace[i].cyclic_softening_v, r.trace[i].normalised_v, 1e-12);
  }
  EXPECT_NEAR(travel, 1000, 1e-9);
  // In a hold the bend response relative to the straight fibre is S(L) times the new fibre's.
  const double v0 = pof::core::quasi_static_voltage(s.sensor.model, 0);
  auto response = [&](std::size_t i) {
    return (r.trace[i].normalised_v - v0) / (pof::core::quasi_static_voltage(s.sensor.model, r.scans[i].angle_true_deg) - v0);
  };
  auto softened = [](double l) { return 1 - 0.1 * (1 - std::exp(-l / 1000)); };
  const std::size_t h30 = hold_at(r, 30).first, h60 = hold_at(r, 60).first;
  const std::size_t end = r.scans.size() - 1;
  ASSERT_EQ(r.trace[end].velocity_rad_s, 0.0);
  EXPECT_NEAR(response(h30), softened(30), 1e-9);
  EXPECT_NEAR(response(h60), softened(60), 1e-9);
  EXPECT_NEAR(r.trace[end].travel_deg, 1000, 1e-9);
  EXPECT_NEAR(response(end), 1 - 0.1 * (1 - std::exp(-1.0)), 1e-9);  // 0.9368 after L0
  const double early = (r.trace[h60].normalised_v - v0) / 60, late = (r.trace[end].normalised_v - v0) / 80;
  std::printf("cyclic softening: depth 0.1, L0 1000 deg: secant sensitivity %.6f V/deg after 60 deg of travel, %.6f after 1000 (%.5f)\n",
              early, late, late / early);
}

TEST(SimCyclicSoftening, LoopShrinksWithLoopDepth) {
  // Maxwell-slip saturates within 20 deg: at 45 deg of a 0-90 cycle the loop is A (S_loop(L_f) +
  // S_loop(L_e)), the travel at the two crossings; with depth 0 the line does not change.
  Scenario s = with_memory(MemoryHysteresisFamily::kMaxwellSlip);
  auto& c = s.sensor.cyclic_softening;
  c.enabled = true;
  c.depth = 0;
  c.loop_depth = 0.3;
  c.travel_scale_deg = 500;
  s.trajectory = {cycles({0.2, 0.2, 0.2, 0.2}, 0, 90, 0.5)};
  const SimRun r = run(s);
  auto v = [](const EffectTrace& t) { return t.normalised_v; };
  auto travel = [](const EffectTrace& t) { return t.travel_deg; };
  auto soft = [](double l) { return 1 - 0.3 * (1 - std::exp(-l / 500)); };
  std::size_t from = 1;
  for (int k = 0; k < 4; ++k) {
    // The k-th cycle: its flexion crossing of 45 deg starts at travel 180 k + 45.
    while (r.trace[from].travel_deg < 180.0 * k + 40) ++from;
    const double loop = at_crossing(r, 0.2, 45, v, from) - at_crossing(r, -0.2, 45, v, from);
    const double lf = at_crossing(r, 0.2, 45, travel, from), le = at_crossing(r, -0.2, 45, travel, from);
    EXPECT_NEAR(lf, 180.0 * k + 45, 1e-6);
    EXPECT_NEAR(loop, 0.025 * (soft(lf) + soft(le)), 1e-9) << k;
  }
}

// ------------------------------------------------------------------------------ determinism
TEST(SimFibreEffects, OffByDefaultAndNoRandomDraws) {
  // New effects configured but disabled change nothing, bit for bit (realistic: every random stream
  // in use); enabled they add exactly their own contribution and leave the noise draws unchanged.
  Scenario base = pof::sim::builtin_scenario("realistic");
  base.duration_s = 60;
  Scenario off = base;
  off.sensor.memory_hysteresis.family = MemoryHysteresisFamily::kMaxwellSlip;
  off.sensor.memory_hysteresis.rate_sensitivity_s_per_rad = 3;
  off.sensor.viscoelastic_lag.tau_s = 2;
  off.sensor.memory_hysteresis.centre_spread_deg = 30;
  off.sensor.power_law_relaxation.exponent = 0.6;
  off.sensor.power_law_relaxation.gain_v_per_deg = 0.01;
  off.sensor.cyclic_softening.depth = 0.5;
  off.sensor.cyclic_softening.loop_depth = 0.5;
  const SimRun a = run(base, 5), b = run(off, 5);
  ASSERT_EQ(a.scans.size(), b.scans.size());
  EXPECT_EQ(std::memcmp(a.scans.data(), b.scans.data(), a.scans.size() * sizeof(Scan)), 0);
  for (const auto& t : a.trace) {
    ASSERT_EQ(t.memory_hysteresis_v, 0.0);
    ASSERT_EQ(t.lag_deg, 0.0);
    ASSERT_EQ(t.viscoelastic_lag_v, 0.0);
    ASSERT_EQ(t.power_law_relaxation_v, 0.0);
    ASSERT_EQ(t.cyclic_softening_v, 0.0);
  }

  Scenario on = base;
  on.daq.bits = 24;
  base.daq.bits = 24;
  on.sensor.memory_hysteresis.enabled = true;
  const SimRun c = run(base, 5), d = run(on, 5);
  std::size_t nonzero = 0;
  for (std::size_t i = 0; i < c.scans.size(); ++i) {
    // The reference channel (same noise draws) is identical; the normalised voltage differs by the
    // memory contribution alone (the light source scales both equally: compare normalised).
    ASSERT_EQ(c.scans[i].reference_v, d.scans[i].reference_v);
    ASSERT_NEAR(d.trace[i].normalised_v - c.trace[i].normalised_v, d.trace[i].memory_hysteresis_v, 1e-12);
    nonzero += d.trace[i].memory_hysteresis_v != 0;
  }
  EXPECT_GT(nonzero, c.scans.size() / 2);
  // The Preisach family and power-law relaxation likewise add only their own term; softening
  // scales terms but draws nothing either.
  Scenario more = on;
  more.sensor.memory_hysteresis.family = MemoryHysteresisFamily::kPreisach;
  more.sensor.power_law_relaxation.enabled = true;
  more.sensor.cyclic_softening.enabled = true;
  const SimRun e = run(more, 5);
  for (std::size_t i = 0; i < c.scans.size(); ++i) {
    ASSERT_EQ(c.scans[i].reference_v, e.scans[i].reference_v);
    ASSERT_NEAR(e.trace[i].normalised_v - c.trace[i].normalised_v,
                e.trace[i].memory_hysteresis_v + e.trace[i].power_law_relaxation_v + e.trace[i].cyclic_softening_v, 1e-12);
  }
}

// ------------------------------------------------------------------------------ random moves
Segment random_moves(int moves, double p) {
  Segment g;
  g.kind = SegmentKind::kRandomMoves;
  g.moves = moves;
  g.min_deg = 15;
  g.max_deg = 75;
  g.min_velocity_rad_s = 0.1;
  g.max_velocity_rad_s = 0.4;
  g.min_hold_s = 0.5;
  g.max_hold_s = 2;
  g.reversal_probability = p;
  return g;
}

TEST(SimRandomMoves, DeterministicWithinRangeAndReversesPartWay) {
  using Step = pof::sim::Trajectory::Step;
  using StepKind = pof::sim::Trajectory::StepKind;
  Scenario s = quiet();
  s.knee.start_deg = 10;
  s.trajectory = {random_moves(12, 1.0)};
  const pof::sim::Trajectory t1(s, 7, 0.005), t1b(s, 7, 0.005), t2(s, 8, 0.005);
  auto same = [](const std::vector<Step>& x, const std::vector<Step>& y) {
    if (x.size() != y.size()) return false;
    for (std::size_t i = 0; i < x.size(); ++i)
      if (x[i].kind != y[i].kind || x[i].target_deg != y[i].target_deg || x[i].speed_deg_s != y[i].speed_deg_s || x[i].ticks != y[i].ticks) return false;
    return true;
  };
  EXPECT_TRUE(same(t1.steps(), t1b.steps()));
  EXPECT_FALSE(same(t1.steps(), t2.steps()));
  // Moves stay in [min_deg, max_deg] (after the first, which brings the knee from 10 deg into the
  // range), at speeds in [min, max]; every move of reversal_probability = 1 is abandoned part-way:
  // a move followed at once (no hold) by one in the opposite direction.
  const auto& st = t1.steps();
  double prev = 10;
  int reversals = 0;
  for (std::size_t i = 0; i < st.size(); ++i) {
    if (st[i].kind != StepKind::kMove) continue;
    EXPECT_GE(st[i].target_deg, 15 - 1e-12);
    EXPECT_LE(st[i].target_deg, 75 + 1e-12);
    if (i > 0) {
      EXPECT_GE(st[i].speed_deg_s, 0.1 * kDegPerRad - 1e-9);
      EXPECT_LE(st[i].speed_deg_s, 0.4 * kDegPerRad + 1e-9);
    }
    if (i + 1 < st.size() && st[i + 1].kind == StepKind::kMove &&
        (st[i].target_deg - prev) * (st[i + 1].target_deg - st[i].target_deg) < 0)
      ++reversals;
    prev = st[i].target_deg;
  }
  EXPECT_EQ(reversals, 12);
  // The simulated knee stays in range and really turns without stopping for a hold.
  const SimRun r = run(s, 7);
  std::size_t in_range = 0;
  while (r.scans[in_range].angle_true_deg < 15 - 1e-9) ++in_range;
  for (std::size_t i = in_range; i < r.scans.size(); ++i) {
    ASSERT_GE(r.scans[i].angle_true_deg, 15 - 1e-9);
    ASSERT_LE(r.scans[i].angle_true_deg, 75 + 1e-9);
  }
  int turns = 0;
  for (std::size_t i = 1; i + 1 < r.scans.size(); ++i)
    turns += r.trace[i].velocity_rad_s == 0 && r.trace[i - 1].velocity_rad_s * r.trace[i + 1].velocity_rad_s < 0;
  EXPECT_GE(turns, 6);

  // reversal_probability = 0: every move ends in a hold.
  s.trajectory = {random_moves(12, 0.0)};
  const pof::sim::Trajectory t0(s, 7, 0.005);
  for (std::size_t i = 1; i + 1 < t0.steps().size(); ++i) {
    if (t0.steps()[i].kind == StepKind::kMove) {
      EXPECT_EQ(t0.steps()[i + 1].kind, StepKind::kHold) << i;
    }
  }
}

TEST(SimRandomMoves, OwnRandomStreamLeavesOtherSegmentsUnchanged) {
  using StepKind = pof::sim::Trajectory::StepKind;
  Segment subj;
  subj.kind = SegmentKind::kSubject;
  subj.velocities_rad_s = {0.16};
  subj.cycles_per_velocity = 3;
  subj.min_deg = 10;
  subj.max_deg = 80;
  subj.velocity_jitter_rel = 0.1;
  subj.amplitude_jitter_deg = 2;
  Scenario a = quiet(), b = quiet();
  a.trajectory = {random_moves(5, 0.5), subj};
  b.trajectory = {random_moves(9, 0.2), subj};
  const pof::sim::Trajectory ta(a, 3, 0.005), tb(b, 3, 0.005);
  auto subject_steps = [](const pof::sim::Trajectory& t) {
    std::vector<double> v;
    for (const auto& s : t.steps())
      if (s.segment == 1 && s.kind == StepKind::kMove) v.push_back(s.target_deg), v.push_back(s.speed_deg_s);
    return v;
  };
  EXPECT_EQ(subject_steps(ta), subject_steps(tb));
  EXPECT_FALSE(subject_steps(ta).empty());
}

// ------------------------------------------------------------------------------ gait at exoskeleton speeds
struct Tracking { double worst_deg = 0, vmax_rad_s = 0; int ticks = 0; };

// Tracking error while the knee follows the gait curves (each gait segment first moves to the
// curve's start and holds 1 s there; measured from the end of that hold).
Tracking gait_tracking(const Scenario& s) {
  pof::sim::Trajectory t(s, 1, 1.0 / s.daq.scan_rate_hz);
  Tracking out;
  int segment = -1, still = 0;
  bool following = false;
  while (!t.finished()) {
    const auto& k = t.step();
    if (t.finished()) break;
    if (k.segment != segment) segment = k.segment, following = false, still = 0;
    if (s.trajectory[static_cast<std::size_t>(segment)].kind != SegmentKind::kGait) continue;
    if (!following) {
      still = k.velocity_deg_s == 0 ? still + 1 : 0;
      following = still >= 150;  // inside the 1-s hold before the curve starts
      continue;
    }
    ++out.ticks;
    out.worst_deg = std::max(out.worst_deg, std::abs(k.commanded_deg - k.angle_deg));
    out.vmax_rad_s = std::max(out.vmax_rad_s, std::abs(k.velocity_deg_s) / kDegPerRad);
  }
  return out;
}

TEST(SimGait, ExoskeletonSpeedsAreTrackedWithTheRecommendedKneeLimits) {
  const Scenario s = pof::sim::builtin_scenario("heldout_gait");
  EXPECT_EQ(s.knee.max_velocity_rad_s, 4.0);
  EXPECT_EQ(s.knee.max_acceleration_rad_s2, 30.0);
  const Tracking g = gait_tracking(s);
  EXPECT_GT(g.ticks, 60 * 200);
  EXPECT_GT(g.vmax_rad_s, 1.5);  // exoskeleton gait: knee speeds of a few rad/s
  EXPECT_LT(g.vmax_rad_s, 4.0);  // below the drive's limit: tracked, not saturated
  EXPECT_LT(g.worst_deg, 1.0);
  // The calibration rig's drive (1 rad/s, 2 rad/s^2) cannot follow the same curves.
  Scenario slow = s;
  slow.knee.max_velocity_rad_s = 1;
  slow.knee.max_acceleration_rad_s2 = 2;
  EXPECT_GT(gait_tracking(slow).worst_deg, 10.0);
  // Period 2 s, swing 65 deg: the fastest gait of the recommended range is still tracked.
  Scenario fast = s;
  fast.trajectory.resize(2);
  fast.trajectory[1].period_s = 2;
  fast.trajectory[1].max_deg = 70;
  const Tracking f = gait_tracking(fast);
  EXPECT_LT(f.vmax_rad_s, 4.0);
  EXPECT_LT(f.worst_deg, 1.5);
  std::printf("gait tracking: heldout_gait %.3f deg (peak %.2f rad/s), 2 s / 65 deg %.3f deg (peak %.2f rad/s)\n",
              g.worst_deg, g.vmax_rad_s, f.worst_deg, f.vmax_rad_s);
}

TEST(SimGait, HeldOutFastGaitPeaksAtThreeToFiveTimesTheFastestCalibrationVelocity) {
  // The fastest commanded speed of the calibration protocol (its table-1 cycles and positioning moves).
  const Scenario cal = pof::sim::builtin_scenario("fibre_calibration");
  double fastest = 0;
  for (const Segment& g : cal.trajectory) {
    fastest = std::max(fastest, g.move_velocity_rad_s);
    for (double v : g.velocities_rad_s) fastest = std::max(fastest, v);
  }
  EXPECT_EQ(fastest, *std::max_element(pof::sim::kTable1Velocities.begin(), pof::sim::kTable1Velocities.end()));
  // Every gait segment of the held-out scenario peaks at 3-5x that on the simulated knee, tracked.
  const Scenario s = pof::sim::builtin_scenario("heldout_fast_gait");
  pof::sim::Trajectory t(s, 1, 1.0 / s.daq.scan_rate_hz);
  std::vector<double> peak(s.trajectory.size(), 0.0);
  double overall = 0;
  while (!t.finished()) {
    const auto& k = t.step();
    if (t.finished()) break;
    const double w = std::abs(k.velocity_deg_s) / kDegPerRad;
    peak[static_cast<std::size_t>(k.segment)] = std::max(peak[static_cast<std::size_t>(k.segment)], w);
    overall = std::max(overall, w);
  }
  int gait = 0;
  for (std::size_t i = 0; i < s.trajectory.size(); ++i) {
    if (s.trajectory[i].kind != SegmentKind::kGait) continue;
    ++gait;
    EXPECT_GE(peak[i], 3 * fastest) << i;
    EXPECT_LE(peak[i], 5 * fastest) << i;
    std::printf("heldout_fast_gait segment %zu: peak %.3f rad/s = %.2fx %.4f rad/s\n", i, peak[i], peak[i] / fastest, fastest);
  }
  EXPECT_GE(gait, 3);
  EXPECT_LE(overall, 5 * fastest);
  const Tracking g = gait_tracking(s);
  EXPECT_GT(g.ticks, 70 * 200);
  EXPECT_LT(g.worst_deg, 1.0);
  std::printf("heldout_fast_gait: tracked within %.3f deg\n", g.worst_deg);
}

// ------------------------------------------------------------------------------ scenarios and keys
TEST(SimFibreScenarios, LoadShareTheFibreAndLastAsPlanned) {
  const Scenario cal = pof::sim::builtin_scenario("fibre_calibration");
  EXPECT_FALSE(cal.sensor.hysteresis.enabled);
  EXPECT_TRUE(cal.sensor.memory_hysteresis.enabled);
  EXPECT_EQ(cal.sensor.memory_hysteresis.family, MemoryHysteresisFamily::kBoucWen);
  EXPECT_LT(cal.sensor.memory_hysteresis.rate_sensitivity_s_per_rad, 0);
  EXPECT_TRUE(cal.sensor.creep.enabled);
  EXPECT_EQ(cal.sensor.creep.terms.size(), 2u);
  EXPECT_EQ(cal.daq.resolution_bits(), 12);
  const Scenario paper = pof::sim::builtin_scenario("paper");
  ASSERT_EQ(cal.trajectory.size(), paper.trajectory.size());
  for (std::size_t i = 0; i < cal.trajectory.size(); ++i) {
    EXPECT_EQ(cal.trajectory[i].kind, paper.trajectory[i].kind);
    EXPECT_EQ(cal.trajectory[i].velocities_rad_s, paper.trajectory[i].velocities_rad_s);
    EXPECT_EQ(cal.trajectory[i].step_deg, paper.trajectory[i].step_deg);
    EXPECT_EQ(cal.trajectory[i].hold_s, paper.trajectory[i].hold_s);
    EXPECT_EQ(cal.trajectory[i].pause_s, paper.trajectory[i].pause_s);
  }
  auto same_sensor = [](const pof::sim::SensorSettings& a, const pof::sim::SensorSettings& b) {
    const auto& x = a.memory_hysteresis;
    const auto& y = b.memory_hysteresis;
    bool same = a.hysteresis.enabled == b.hysteresis.enabled && x.enabled == y.enabled && x.family == y.family &&
                x.amplitude_v == y.amplitude_v && x.width_deg == y.width_deg && x.shape == y.shape &&
                x.beta_fraction == y.beta_fraction && x.rate_sensitivity_s_per_rad == y.rate_sensitivity_s_per_rad &&
                x.rate_filter_s == y.rate_filter_s && a.creep.enabled == b.creep.enabled &&
                a.creep.terms.size() == b.creep.terms.size() && a.static_nonlinearity.enabled == b.static_nonlinearity.enabled &&
                a.static_nonlinearity.bow_v == b.static_nonlinearity.bow_v &&
                a.viscoelastic_lag.enabled == b.viscoelastic_lag.enabled;
    for (std::size_t i = 0; same && i < a.creep.terms.size(); ++i)
      same = a.creep.terms[i].tau_s == b.creep.terms[i].tau_s && a.creep.terms[i].gain_v_per_deg == b.creep.terms[i].gain_v_per_deg;
    return same;
  };
  struct Want { const char* name; double lo_s, hi_s; };
  for (const Want w : {Want{"fibre_session", 90, 120}, Want{"heldout_gait", 60, 90}, Want{"heldout_fast_gait", 80, 110},
                       Want{"heldout_rehab", 120, 200}, Want{"heldout_random", 100, 140}}) {
    const Scenario s = pof::sim::builtin_scenario(w.name);
    EXPECT_TRUE(same_sensor(s.sensor, cal.sensor)) << w.name;
    EXPECT_EQ(s.daq.resolution_bits(), 12) << w.name;
    const SimRun r = run(s);
    const double dur = r.scans.back().t_s;
    EXPECT_GE(dur, w.lo_s) << w.name;
    EXPECT_LE(dur, w.hi_s) << w.name;
    for (const auto& x : r.scans) ASSERT_EQ(x.over_range, 0) << w.name;
  }
  EXPECT_EQ(pof::sim::builtin_scenario("fibre_session").sensor_id, "SIM_FIBRE");
  // The session's random moves include at least one part-way reversal.
  const Scenario fs = pof::sim::builtin_scenario("fibre_session");
  EXPECT_EQ(fs.trajectory.back().kind, SegmentKind::kRandomMoves);
  EXPECT_GT(fs.trajectory.back().reversal_probability, 0);
}

TEST(SimFibreScenarios, CalibrationLoopNarrowsWithSpeedLikeThePaper) {
  // The loop height at 45 deg (flexion minus extension, noise-free normalised voltage) over the
  // span f5^-1(0) - f5^-1(90) = 1.971 V: ~2.5 % at the slowest table-1 speed, < 1 % at the fastest
  // (paper: f1 = 2.64 exp(-3.49 w) %, 2.46 % and 0.59 %).
  Scenario s = pof::sim::builtin_scenario("fibre_calibration");
  s.daq.noise.enabled = false;
  const SimRun r = run(s);
  auto v = [](const EffectTrace& t) { return t.normalised_v; };
  const double span = 0.0219 * 90;
  const double slow = (at_crossing(r, 0.0209, 45, v) - at_crossing(r, -0.0209, 45, v)) / span * 100;
  const double fast = (at_crossing(r, 0.4304, 45, v) - at_crossing(r, -0.4304, 45, v)) / span * 100;
  EXPECT_GT(slow, 2.2);
  EXPECT_LT(slow, 2.8);
  EXPECT_GT(fast, 0.6);
  EXPECT_LT(fast, 1.0);
}

TEST(SimFibreScenarios, BadKeysAreNamed) {
  std::string e = config_error(kMinimal + "[sensor.memory_hysteresis]\nenabled = true\nfamily = \"nope\"\n");
  EXPECT_NE(e.find("t.toml:7: key 'sensor.memory_hysteresis.family': expected one of 'bouc_wen', 'maxwell_slip', 'preisach', got 'nope'"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.memory_hysteresis]\nenabled = true\nfamily = \"preisach\"\ncentre_spread_deg = -1\n");
  EXPECT_NE(e.find("t.toml:8: key 'sensor.memory_hysteresis.centre_spread_deg': expected a spread in [0, 90] deg, got -1"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.memory_hysteresis]\nhalf_width_deg = 0\n");
  EXPECT_NE(e.find("t.toml:6: key 'sensor.memory_hysteresis.half_width_deg': expected a half-width in (0, 90] deg, got 0"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.power_law_relaxation]\nenabled = true\nexponent = 1\n");
  EXPECT_NE(e.find("t.toml:7: key 'sensor.power_law_relaxation.exponent': expected an exponent in (0, 1), got 1"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.power_law_relaxation]\nmin_time_s = 10\nmax_time_s = 50\n");
  EXPECT_NE(e.find("key 'sensor.power_law_relaxation.max_time_s': expected max_time_s / min_time_s in [10, 1e8]"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.power_law_relaxation]\nmin_time_s = 0\n");
  EXPECT_NE(e.find("t.toml:6: key 'sensor.power_law_relaxation.min_time_s'"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.cyclic_softening]\nenabled = true\ndepth = 1\n");
  EXPECT_NE(e.find("t.toml:7: key 'sensor.cyclic_softening.depth': expected a fraction in [0, 1), got 1"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.cyclic_softening]\ntravel_scale_deg = -5\n");
  EXPECT_NE(e.find("t.toml:6: key 'sensor.cyclic_softening.travel_scale_deg': expected a travel in (0, 1e9] deg, got -5"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.cyclic_softening]\ntravel_scale = 500\n");
  EXPECT_NE(e.find("t.toml:6: unknown key 'travel_scale' in [sensor.cyclic_softening] (did you mean 'travel_scale_deg'?)"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.memory_hysteresis]\nwidth_deg = -3\n");
  EXPECT_NE(e.find("t.toml:6: key 'sensor.memory_hysteresis.width_deg': expected an angle in (0, 180] deg, got -3"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.memory_hysteresis]\nwidht_deg = 3\n");
  EXPECT_NE(e.find("t.toml:6: unknown key 'widht_deg' in [sensor.memory_hysteresis] (did you mean 'width_deg'?)"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.memory_hysteresis]\nthresholds_deg = [1, 2]\nweights = [1, 1, 1]\n");
  EXPECT_NE(e.find("'sensor.memory_hysteresis.weights': expected as many entries as thresholds_deg (2), got 3"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.memory_hysteresis]\nthresholds_deg = [1, 0]\n");
  EXPECT_NE(e.find("'sensor.memory_hysteresis.thresholds_deg[1]'"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.memory_hysteresis]\nweights = [0, 0, 0]\n");
  EXPECT_NE(e.find("'sensor.memory_hysteresis.weights': expected at least one weight > 0"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.memory_hysteresis]\nbeta_fraction = 0\n");
  EXPECT_NE(e.find("'sensor.memory_hysteresis.beta_fraction'"), std::string::npos) << e;
  e = config_error(kMinimal + "[sensor.viscoelastic_lag]\ntau_s = -0.3\n");
  EXPECT_NE(e.find("'sensor.viscoelastic_lag.tau_s': expected a time constant in (0, 600] s, got -0.3"), std::string::npos) << e;
  e = config_error("schema_version = 1\n[[trajectory]]\nkind = \"random_moves\"\nreversal_probability = 1.5\n");
  EXPECT_NE(e.find("t.toml:4: key 'trajectory[0].reversal_probability': expected a probability in [0, 1], got 1.5"), std::string::npos) << e;
  e = config_error("schema_version = 1\n[[trajectory]]\nkind = \"random_moves\"\nmin_velocity_rad_s = 0.3\nmax_velocity_rad_s = 0.2\n");
  EXPECT_NE(e.find("'trajectory[0].max_velocity_rad_s'"), std::string::npos) << e;
  e = config_error("schema_version = 1\n[[trajectory]]\nkind = \"random_moves\"\nduration_s = 3\n");
  EXPECT_NE(e.find("t.toml:4: unknown key 'duration_s' in trajectory[0]"), std::string::npos) << e;
  // Creep (Prony) terms from 0.5 s to 60 s, and a full memory section, are accepted.
  e = config_error(kMinimal + "[sensor.creep]\nenabled = true\nterms = [ { tau_s = 0.5, gain_v_per_deg = -0.0003 }, { tau_s = 60, gain_v_per_deg = -0.0001 } ]\n"
                   "[sensor.memory_hysteresis]\nenabled = true\nfamily = \"maxwell_slip\"\namplitude_v = -0.02\nrate_sensitivity_s_per_rad = 1\n"
                   "rate_filter_s = 0\nthresholds_deg = [1, 4, 9]\nweights = [0.2, 0.5, 0.3]\n[sensor.viscoelastic_lag]\nenabled = true\ntau_s = 0.5\n");
  EXPECT_EQ(e, "(no error)");
  e = config_error(kMinimal + "[sensor.memory_hysteresis]\nenabled = true\nfamily = \"preisach\"\ncentre_deg = 40\ncentre_spread_deg = 0\n"
                   "half_width_deg = 20\nhalf_width_spread_deg = 0\n[sensor.power_law_relaxation]\nenabled = true\ngain_v_per_deg = -0.0002\n"
                   "exponent = 0.25\nmin_time_s = 0.05\nmax_time_s = 1000\n[sensor.cyclic_softening]\nenabled = true\ndepth = 0.08\n"
                   "loop_depth = 0.2\ntravel_scale_deg = 20000\n");
  EXPECT_EQ(e, "(no error)");
  // Scenarios built in code are checked by the simulator's constructor (validate()).
  Scenario s = quiet();
  s.trajectory = {go(10, 0.1, 1)};
  s.sensor.memory_hysteresis.width_deg = -1;
  try {
    pof::sim::Simulator sim(s, 1, 0);
    ADD_FAILURE() << "no error";
  } catch (const pof::ConfigError& err) {
    EXPECT_NE(std::string(err.what()).find("'sensor.memory_hysteresis.width_deg'"), std::string::npos) << err.what();
  }
  s.sensor.memory_hysteresis.width_deg = 10;
  s.sensor.memory_hysteresis.family = MemoryHysteresisFamily::kMaxwellSlip;
  s.sensor.memory_hysteresis.weights = {1};
  EXPECT_THROW(pof::sim::Simulator(s, 1, 0), pof::ConfigError);
  s.sensor.memory_hysteresis.weights = {1, 1, 1};
  s.sensor.power_law_relaxation.exponent = 0;
  try {
    pof::sim::Simulator sim(s, 1, 0);
    ADD_FAILURE() << "no error";
  } catch (const pof::ConfigError& err) {
    EXPECT_NE(std::string(err.what()).find("'sensor.power_law_relaxation.exponent'"), std::string::npos) << err.what();
  }
  s.sensor.power_law_relaxation.exponent = 0.3;
  s.sensor.cyclic_softening.travel_scale_deg = 0;
  EXPECT_THROW(pof::sim::Simulator(s, 1, 0), pof::ConfigError);
}

}  // namespace
