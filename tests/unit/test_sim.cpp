// pof_sim: scenario loading, the knee trajectory, and each effect switched on alone against the
// physics it claims (docs/simulator.md). Effects are isolated by running the same scenario and
// seed with the effect off and on: every noise source has its own random stream (rng.hpp), so the
// difference is the effect alone (noise is switched off anyway, and a 24-bit converter keeps the
// quantisation far below the tolerances unless the test is about quantisation).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstring>
#include <numbers>
#include <numeric>
#include <vector>

#include "pof/core/model.hpp"
#include "pof/base/errors.hpp"
#include "pof/sim/effects.hpp"
#include "pof/sim/scenario.hpp"
#include "pof/sim/simulator.hpp"

namespace {

using pof::sim::Scan;
using pof::sim::Scenario;
using pof::sim::EffectTrace;

struct SimRun {
  std::vector<Scan> scans;
  std::vector<EffectTrace> trace;
};

SimRun run(const Scenario& s, std::uint64_t seed = 1, double rate = 0) {
  pof::sim::Simulator sim(s, seed, rate);
  SimRun r;
  std::vector<Scan> buf(1000);
  std::vector<EffectTrace> tb(1000);
  for (;;) {
    const std::size_t n = sim.next(buf, tb);
    if (n == 0) break;
    r.scans.insert(r.scans.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
    r.trace.insert(r.trace.end(), tb.begin(), tb.begin() + static_cast<std::ptrdiff_t>(n));
  }
  return r;
}

// The paper scenario, noise-free, with a 24-bit converter (LSB 0.6 uV) and no multiplexing.
Scenario clean() {
  Scenario s = pof::sim::builtin_scenario("paper");
  s.daq.noise.enabled = false;
  s.daq.bits = 24;
  s.daq.multiplexed = false;
  return s;
}
Scenario clean_quasi_static() {
  Scenario s = clean();
  s.trajectory.resize(1);  // the quasi-static test only (0-90 deg, 5 deg steps, 10 s holds)
  return s;
}
Scenario clean_cycles() {
  Scenario s = clean();
  s.trajectory.erase(s.trajectory.begin());  // table 1 cycles only
  return s;
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

// Amplitude of the frequency-f component of x sampled at fs (one DFT bin).
double amplitude_at(const std::vector<double>& x, double fs, double f) {
  std::complex<double> acc{0, 0};
  for (std::size_t i = 0; i < x.size(); ++i)
    acc += x[i] * std::polar(1.0, -2 * std::numbers::pi * f * static_cast<double>(i) / fs);
  return 2.0 * std::abs(acc) / static_cast<double>(x.size());
}

// Indices of the holds (zero velocity) that last at least min_scans, as [begin, end) ranges.
std::vector<std::pair<std::size_t, std::size_t>> holds(const SimRun& r, std::size_t min_scans) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  std::size_t i = 0;
  while (i < r.trace.size()) {
    if (r.trace[i].velocity_rad_s != 0) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < r.trace.size() && r.trace[j].velocity_rad_s == 0) ++j;
    if (j - i >= min_scans) out.emplace_back(i, j);
    i = j;
  }
  return out;
}

// ------------------------------------------------------------------------------ scenarios
TEST(SimScenario, BuiltinsLoadAndMatchThePaperProtocol) {
  const auto names = pof::sim::builtin_scenario_names();
  ASSERT_EQ(names, (std::vector<std::string>{"paper", "validation", "session", "realistic", "fibre_calibration",
                                             "fibre_session", "heldout_gait", "heldout_rehab", "heldout_random",
                                             "heldout_fast_gait"}));
  for (const auto& n : names) EXPECT_NO_THROW((void)pof::sim::builtin_scenario(n)) << n;
  const Scenario p = pof::sim::builtin_scenario("paper");
  EXPECT_EQ(p.name, "paper");
  EXPECT_EQ(p.daq.scan_rate_hz, 200.0);
  EXPECT_EQ(p.daq.resolution_bits(), 12);
  EXPECT_DOUBLE_EQ(p.daq.lsb_v(), 10.0 / 4096.0);
  ASSERT_EQ(p.trajectory.size(), 2u);
  EXPECT_EQ(p.trajectory[0].kind, pof::sim::SegmentKind::kQuasiStatic);
  EXPECT_EQ(p.trajectory[1].velocities_rad_s.size(), 9u);
  EXPECT_DOUBLE_EQ(p.trajectory[1].velocities_rad_s[4], 0.0898);
  const Scenario v = pof::sim::builtin_scenario("validation");
  ASSERT_EQ(v.trajectory.size(), 2u);
  EXPECT_EQ(v.trajectory[0].kind, pof::sim::SegmentKind::kCycles);  // the table-3 preset
  EXPECT_EQ(v.trajectory[0].velocities_rad_s, (std::vector<double>{0.05, 0.10, 0.16, 0.21, 0.26}));
  EXPECT_EQ(v.trajectory[1].kind, pof::sim::SegmentKind::kSubject);
  const Scenario r = pof::sim::builtin_scenario("realistic");
  EXPECT_TRUE(r.sensor.creep.enabled);
  EXPECT_EQ(r.sensor.creep.terms.size(), 2u);
  EXPECT_THROW((void)pof::sim::builtin_scenario("nope"), pof::NoInputError);
  EXPECT_THROW((void)pof::sim::load_scenario("/nonexistent/x.toml"), pof::NoInputError);
}

// How `sim:<x>` (daq.toml) and the virtual devices' --sim-scenario name a scenario.
TEST(SimScenario, ByNameOrPath) {
  EXPECT_EQ(pof::sim::scenario_by_name_or_path("session").name, "session");
  const auto file = pof::sim::scenario_by_name_or_path(std::string(POF_SOURCE_DIR) + "/daq/sim/scenarios/paper.toml");
  EXPECT_NE(file.source.find("paper.toml"), std::string::npos);
  EXPECT_THROW((void)pof::sim::scenario_by_name_or_path("no_such_scenario"), pof::NoInputError);
  EXPECT_THROW((void)pof::sim::scenario_by_name_or_path("missing.toml"), pof::NoInputError);
}

TEST(SimScenario, ErrorsNameFileLineAndKey) {
  EXPECT_EQ(config_error(kMinimal), "(no error)");
  std::string e = config_error(kMinimal + "[sensor.creep]\nenabled = true\ntua_s = 3\n");
  EXPECT_NE(e.find("t.toml:7: unknown key 'tua_s' in [sensor.creep]"), std::string::npos) << e;
  e = config_error(kMinimal + "[daq]\nscan_rate = 200\n");
  EXPECT_EQ(e, "t.toml:6: unknown key 'scan_rate' in [daq] (did you mean 'scan_rate_hz'?)");
  e = config_error("schema_version = 1\nnmae = \"x\"\n[[trajectory]]\nkind = \"hold\"\n");
  EXPECT_EQ(e, "t.toml:2: unknown key 'nmae' at the top level (did you mean 'name'?)");
  e = config_error(kMinimal + "[sensor.creep]\nterms = [ { tau_s = -1, gain_v_per_deg = 0.001 } ]\n");
  EXPECT_NE(e.find("'sensor.creep.terms[0].tau_s'"), std::string::npos) << e;
  EXPECT_NE(e.find("> 0"), std::string::npos) << e;
  e = config_error(kMinimal + "[daq]\nrange_v = \"five\"\n");
  EXPECT_NE(e.find("t.toml:6: key 'daq.range_v': expected a number, got a string 'five'"), std::string::npos) << e;
  e = config_error(kMinimal + "[daq]\nterminal = \"rse\"\nrange_v = 5\n");
  EXPECT_NE(e.find("'daq.range_v'"), std::string::npos) << e;
  e = config_error(kMinimal + "[daq]\ndevice = \"usb6010\"\n");
  EXPECT_NE(e.find("'daq.device': expected one of 'usb6008', 'usb6009'"), std::string::npos) << e;
  e = config_error("[[trajectory]]\nkind = \"hold\"\n");
  EXPECT_NE(e.find("'schema_version': missing"), std::string::npos) << e;
  e = config_error("schema_version = 2\n[[trajectory]]\nkind = \"hold\"\n");
  EXPECT_NE(e.find("'schema_version'"), std::string::npos) << e;
  e = config_error("schema_version = 1\n[[trajectory]]\nkind = \"jog\"\n");
  EXPECT_NE(e.find("'trajectory[0].kind'"), std::string::npos) << e;
  e = config_error("schema_version = 1\n");
  EXPECT_NE(e.find("'trajectory': missing"), std::string::npos) << e;
  e = config_error("schema_version = 1\n[[trajectory]]\nkind = \"cycles\"\nvelocities_rad_s = [0.1, 0]\n");
  EXPECT_NE(e.find("'trajectory[0].velocities_rad_s[1]'"), std::string::npos) << e;
  e = config_error(kMinimal + "[light.steps]\nat_s = [1, 2]\nrelative_change = [0.1]\n");
  EXPECT_NE(e.find("'light.steps.relative_change'"), std::string::npos) << e;
  e = config_error(kMinimal + "[daq.time_delay]\nchannel = \"angle\"\n");
  EXPECT_NE(e.find("'daq.time_delay.channel'"), std::string::npos) << e;
  e = config_error("schema_version = 1\n[knee\n");
  EXPECT_NE(e.find("t.toml:2: TOML syntax error"), std::string::npos) << e;
}

TEST(SimScenario, EffectSwitchesCoverTheGapVocabulary) {
  Scenario s = pof::sim::builtin_scenario("paper");
  for (auto id : pof::core::kEffectIds) {
    bool* sw = pof::sim::effect_switch(s, id);
    ASSERT_NE(sw, nullptr) << id;
    EXPECT_FALSE(*sw) << id << " is off in the paper scenario";
  }
  EXPECT_EQ(pof::sim::effect_switch(s, "gremlins"), nullptr);
  Scenario r = pof::sim::builtin_scenario("realistic");
  pof::sim::disable_all_effects(r);
  for (auto id : pof::core::kEffectIds) EXPECT_FALSE(*pof::sim::effect_switch(r, id)) << id;
  EXPECT_TRUE(r.sensor.hysteresis.enabled);
}

// ------------------------------------------------------------------------------ trajectory
TEST(SimTrajectory, QuasiStaticStepsAndTable1Velocities) {
  const SimRun r = run(clean());
  const auto h = holds(r, 1900);  // 10 s holds at 200 Hz (less a tick or two)
  ASSERT_GE(h.size(), 19u);
  for (std::size_t k = 0; k < 19; ++k) {
    EXPECT_NEAR(r.scans[h[k].first].angle_true_deg, 5.0 * static_cast<double>(k), 1e-9);
    EXPECT_NEAR(static_cast<double>(h[k].second - h[k].first), 2000.0, 2.0);
  }
  // Every table-1 velocity is reached exactly and held, in both directions.
  for (double v : pof::sim::kTable1Velocities) {
    std::size_t flex = 0, ext = 0;
    for (const auto& t : r.trace) {
      flex += std::abs(t.velocity_rad_s - v) < 1e-12;
      ext += std::abs(t.velocity_rad_s + v) < 1e-12;
    }
    const double stroke_scans = (std::numbers::pi / 2) / v * 200.0;
    EXPECT_GT(static_cast<double>(flex), 0.95 * stroke_scans - 40) << v;
    EXPECT_GT(static_cast<double>(ext), 0.95 * stroke_scans - 40) << v;
  }
  const double amax = 2.0;
  for (const auto& t : r.trace) {
    EXPECT_LE(std::abs(t.velocity_rad_s), 1.0 + 1e-12);
    // The drive's limit, except the final tick of a move that stops on the target (<= 2 amax).
    EXPECT_LE(std::abs(t.acceleration_rad_s2), 2 * amax + 1e-9);
  }
  for (const auto& s : r.scans) {
    EXPECT_GE(s.angle_true_deg, -1e-9);
    EXPECT_LE(s.angle_true_deg, 90 + 1e-9);
  }
}

TEST(SimTrajectory, Table3SubjectAndGait) {
  Scenario s = clean();
  s.trajectory.clear();
  pof::sim::Segment t3;
  t3.kind = pof::sim::SegmentKind::kCycles;
  t3.velocities_rad_s.assign(pof::sim::kTable3Velocities.begin(), pof::sim::kTable3Velocities.end());
  t3.cycles_per_velocity = 3;
  t3.min_deg = 10;
  t3.max_deg = 80;
  s.trajectory.push_back(t3);
  SimRun r = run(s);
  int tops = 0;
  for (std::size_t i = 1; i + 1 < r.scans.size(); ++i)
    tops += r.trace[i - 1].velocity_rad_s > 0 && r.trace[i].velocity_rad_s == 0 && std::abs(r.scans[i].angle_true_deg - 80) < 1e-9;
  EXPECT_EQ(tops, 15);  // 5 velocities x 3 cycles

  pof::sim::Segment subj;
  subj.kind = pof::sim::SegmentKind::kSubject;
  subj.velocities_rad_s = {0.16};
  subj.cycles_per_velocity = 5;
  subj.min_deg = 10;
  subj.max_deg = 80;
  subj.velocity_jitter_rel = 0.1;
  subj.amplitude_jitter_deg = 2;
  s.trajectory = {subj};
  auto peaks = [](const SimRun& x) {
    std::vector<double> p;
    for (std::size_t i = 1; i < x.scans.size(); ++i)
      if (x.trace[i - 1].velocity_rad_s > 0 && x.trace[i].velocity_rad_s == 0 && x.scans[i].angle_true_deg > 45)
        p.push_back(x.scans[i].angle_true_deg);
    return p;
  };
  const auto p1 = peaks(run(s, 1)), p1b = peaks(run(s, 1)), p2 = peaks(run(s, 2));
  ASSERT_EQ(p1.size(), 5u);
  EXPECT_EQ(p1, p1b);
  EXPECT_NE(p1, p2);
  for (double p : p1) EXPECT_NEAR(p, 80, 8);

  pof::sim::Segment gait;
  gait.kind = pof::sim::SegmentKind::kGait;
  gait.cycles = 3;
  gait.period_s = 10;
  gait.min_deg = 5;
  gait.max_deg = 60;
  s.trajectory = {gait};
  r = run(s);
  double vmin = 0, vmax = 0, amax = 0;
  for (const auto& t : r.trace) {
    vmin = std::min(vmin, t.velocity_rad_s);
    vmax = std::max(vmax, t.velocity_rad_s);
    amax = std::max(amax, std::abs(t.acceleration_rad_s2));
  }
  EXPECT_GT(vmax, 0.2);   // variable velocity, both directions
  EXPECT_LT(vmin, -0.2);
  EXPECT_LE(vmax, 1.0 + 1e-12);
  EXPECT_LE(amax, 2 * 2.0 + 1e-9);  // the limit, except the stop at the end (see above)
  const auto mx = std::max_element(r.scans.begin(), r.scans.end(), [](auto& a, auto& b) { return a.angle_true_deg < b.angle_true_deg; });
  EXPECT_NEAR(mx->angle_true_deg, 60, 4);
}

// ------------------------------------------------------------------------------ the paper's model
TEST(SimPaper, EffectsOffReproducesModelVoltageWithinQuantisation) {
  Scenario s = pof::sim::builtin_scenario("paper");
  s.daq.noise.enabled = false;
  const SimRun r = run(s);
  const double lsb = s.daq.lsb_v();
  const auto m = pof::core::paper_coefficients();
  double worst = 0;
  std::size_t moving = 0;
  for (std::size_t i = 0; i < r.scans.size(); ++i) {
    const double w = std::abs(r.trace[i].velocity_rad_s);
    const auto dir = w < 0.01 ? pof::core::Direction::kHold
                              : (r.trace[i].velocity_rad_s > 0 ? pof::core::Direction::kFlexion : pof::core::Direction::kExtension);
    moving += dir != pof::core::Direction::kHold;
    const double v = pof::core::model_voltage(m, r.scans[i].angle_true_deg, w, dir);
    worst = std::max(worst, std::abs(r.scans[i].sensor_v - v));
    ASSERT_LE(std::abs(r.scans[i].reference_v - 4.0), lsb / 2 + 1e-12);
  }
  EXPECT_LE(worst, lsb / 2 + 1e-12);
  EXPECT_GT(moving, r.scans.size() / 2);
  // Eq. (11)/(12) invert it: the compensated angle equals the true angle within a quantum.
  const double deg_per_lsb = lsb * m.c9 * 1.2;
  for (std::size_t i = 0; i < r.scans.size(); i += 97) {
    const double w = std::abs(r.trace[i].velocity_rad_s);
    if (w < 0.02) continue;
    const auto dir = r.trace[i].velocity_rad_s > 0 ? pof::core::Direction::kFlexion : pof::core::Direction::kExtension;
    EXPECT_NEAR(pof::core::compensated_angle(m, r.scans[i].sensor_v, w, dir), r.scans[i].angle_true_deg, deg_per_lsb);
  }
  // Paper-consistent voltages (brief): ~4.35 V at 0 deg, ~2.38 V at 90 deg.
  EXPECT_NEAR(r.scans.front().sensor_v, 4.35, 0.01);
}

TEST(SimPaper, DeterministicPerSeed) {
  Scenario s = pof::sim::builtin_scenario("realistic");
  s.duration_s = 120;
  const SimRun a = run(s, 7), b = run(s, 7), c = run(s, 8);
  ASSERT_EQ(a.scans.size(), 24000u);
  ASSERT_EQ(a.scans.size(), b.scans.size());
  EXPECT_EQ(std::memcmp(a.scans.data(), b.scans.data(), a.scans.size() * sizeof(Scan)), 0);
  ASSERT_EQ(a.scans.size(), c.scans.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a.scans.size(); ++i) differ += a.scans[i].sensor_v != c.scans[i].sensor_v;
  EXPECT_GT(differ, a.scans.size() / 2);
}

TEST(SimPaper, StreamingInChunksEqualsOneGoAndStops) {
  Scenario s = pof::sim::builtin_scenario("realistic");
  s.duration_s = 10;
  const SimRun whole = run(s, 3);
  pof::sim::Simulator sim(s, 3, 0);
  std::vector<Scan> got;
  std::vector<Scan> buf(7);
  while (!sim.finished()) {
    const std::size_t n = sim.next(std::span<Scan>(buf.data(), 1 + got.size() % 7));
    got.insert(got.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
    if (n == 0) break;
  }
  ASSERT_EQ(got.size(), whole.scans.size());
  EXPECT_EQ(std::memcmp(got.data(), whole.scans.data(), got.size() * sizeof(Scan)), 0);
  EXPECT_EQ(sim.next(buf), 0u);
  EXPECT_TRUE(sim.finished());
}

TEST(SimPaper, RateOverrideAndLoop) {
  Scenario s = clean();
  s.trajectory.resize(1);
  s.trajectory[0].to_deg = 10;  // 0, 5, 10 deg: ~32 s
  s.loop = true;
  s.duration_s = 100;
  pof::sim::Simulator sim(s, 1, 1000);
  EXPECT_EQ(sim.scan_rate_hz(), 1000);
  std::vector<Scan> v(100000 + 10);
  const std::size_t n = sim.next(v);
  EXPECT_EQ(n, 100000u);
  EXPECT_DOUBLE_EQ(v[1].t_s, 0.001);
  // The trajectory restarted: the knee came back to 0 after the first pass and went up again.
  int returns = 0;
  for (std::size_t i = 1; i < n; ++i) returns += v[i - 1].angle_true_deg > 0 && v[i].angle_true_deg == 0;
  EXPECT_GE(returns, 2);
  EXPECT_THROW(pof::sim::Simulator(s, 1, -5), pof::ConfigError);
}

// ------------------------------------------------------------------------------ effects, one at a time
TEST(SimEffect, CreepDecaysInHoldsWithTheConfiguredTimeConstant) {
  Scenario off = clean_quasi_static(), on = off;
  on.sensor.creep.enabled = true;
  on.sensor.creep.terms = {{4.0, -0.002}};
  const SimRun a = run(off), b = run(on);
  const auto h = holds(a, 1900);
  ASSERT_GE(h.size(), 10u);
  for (std::size_t k : {3u, 9u, 15u}) {
    // Fit log|creep| = log A - t/tau over the hold (after the step's flexion: negative voltage).
    double sx = 0, sy = 0, sxx = 0, sxy = 0, n = 0;
    for (std::size_t i = h[k].first + 20; i < h[k].second; ++i) {
      const double d = b.scans[i].sensor_v - a.scans[i].sensor_v;
      ASSERT_LT(d, 0) << "relaxation after a flexion step lowers the voltage (gain < 0)";
      const double x = b.scans[i].t_s, y = std::log(-d);
      sx += x, sy += y, sxx += x * x, sxy += x * y, n += 1;
    }
    const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    EXPECT_NEAR(-1.0 / slope, 4.0, 0.04) << "hold " << k;
  }
  // Two Prony terms: the sum of two exponentials (fast one gone after 5 tau -> slow one's tau).
  on.sensor.creep.terms = {{0.5, -0.002}, {6.0, -0.001}};
  const SimRun c = run(on);
  const auto [b0, e0] = h[5];
  const double d1 = c.scans[b0 + 1000].sensor_v - a.scans[b0 + 1000].sensor_v;
  const double d2 = c.scans[b0 + 1800].sensor_v - a.scans[b0 + 1800].sensor_v;
  EXPECT_NEAR(4.0 / std::log(d1 / d2), 6.0, 0.06);
}

TEST(SimEffect, ChannelDelayShowsAsCrossCorrelationLag) {
  Scenario off = clean_cycles();
  // Without the paper's hysteresis the sensor is a straight function of the angle, so the
  // hysteresis jumps at the start and end of each stroke do not dominate the correlation.
  off.sensor.hysteresis.enabled = false;
  Scenario on = off;
  on.daq.time_delay.enabled = true;
  on.daq.time_delay.channel = pof::sim::Channel::kSensor;
  on.daq.time_delay.delay_s = 0.05;  // 10 scans at 200 Hz
  const SimRun a = run(off), b = run(on);
  ASSERT_EQ(a.scans.size(), b.scans.size());
  // Cross-correlate the sample-to-sample changes of the delayed sensor with the reference angle's
  // (the sensor voltage falls as the angle rises, so the peak is negative).
  auto diff = [](const std::vector<Scan>& s, auto get) {
    std::vector<double> d(s.size() - 1);
    for (std::size_t i = 1; i < s.size(); ++i) d[i - 1] = get(s[i]) - get(s[i - 1]);
    return d;
  };
  const auto ds = diff(b.scans, [](const Scan& x) { return -x.sensor_v; });
  const auto da = diff(b.scans, [](const Scan& x) { return x.angle_ref_deg; });
  const auto ds0 = diff(a.scans, [](const Scan& x) { return -x.sensor_v; });
  auto peak_lag = [&](const std::vector<double>& x) {
    int best = 0;
    double best_c = -1e300;
    for (int lag = -30; lag <= 30; ++lag) {
      double c = 0;
      for (std::size_t i = 40; i + 40 < x.size(); ++i) c += x[i] * da[static_cast<std::size_t>(static_cast<std::ptrdiff_t>(i) - lag)];
      if (c > best_c) best_c = c, best = lag;
    }
    return best;
  };
  EXPECT_EQ(peak_lag(ds0), 0);
  EXPECT_EQ(peak_lag(ds), 10);
  // The delayed channel is the undelayed one 10 scans later.
  for (std::size_t i = 10; i < a.scans.size(); i += 37) EXPECT_DOUBLE_EQ(b.scans[i].sensor_v, a.scans[i - 10].sensor_v);
}

TEST(SimEffect, BacklashIsADeadBandAtReversals) {
  Scenario s = clean_cycles();
  s.knee.backlash.enabled = true;
  s.knee.backlash.width_deg = 1.0;
  const SimRun r = run(s);
  std::vector<double> flex, ext;
  for (std::size_t i = 0; i < r.scans.size(); ++i) {
    const double e = r.scans[i].angle_true_deg - r.scans[i].angle_ref_deg;
    if (std::abs(r.trace[i].velocity_rad_s) > 0.02) (r.trace[i].velocity_rad_s > 0 ? flex : ext).push_back(e);
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  EXPECT_NEAR(median(flex), 0.5, 1e-3);   // the pot trails by half the play
  EXPECT_NEAR(median(ext), -0.5, 1e-3);
  // First reversal at 90 deg: the pot does not move until the knee has come back the full width.
  std::size_t top = 0;
  while (r.scans[top].angle_true_deg < 90 - 1e-9) ++top;
  const double ref_at_top = r.scans[top].angle_ref_deg;
  EXPECT_NEAR(ref_at_top, 89.5, 1e-3);
  for (std::size_t i = top; r.scans[i].angle_true_deg > 89.0 + 1e-6; ++i) EXPECT_NEAR(r.scans[i].angle_ref_deg, ref_at_top, 1e-5);
  std::size_t i = top;
  while (r.scans[i].angle_true_deg > 88.0) ++i;
  EXPECT_LT(r.scans[i].angle_ref_deg, ref_at_top - 0.9);
}

TEST(SimEffect, DriftHasTheConfiguredSlope) {
  Scenario off = clean_quasi_static(), on = off;
  on.sensor.drift.enabled = true;
  on.sensor.drift.rate_v_per_hour = 0.1;
  on.sensor.drift.random_walk_v_per_sqrt_hour = 0;
  const SimRun a = run(off), b = run(on);
  double sx = 0, sy = 0, sxx = 0, sxy = 0, n = 0;
  for (std::size_t i = 0; i < a.scans.size(); ++i) {
    const double x = a.scans[i].t_s, y = b.scans[i].sensor_v - a.scans[i].sensor_v;
    sx += x, sy += y, sxx += x * x, sxy += x * y, n += 1;
  }
  EXPECT_NEAR((n * sxy - sx * sy) / (n * sxx - sx * sx) * 3600, 0.1, 1e-4);
  // The random walk: its increments over 1 s have the configured spread (sigma * sqrt(1 s / 1 h)).
  on.sensor.drift.rate_v_per_hour = 0;
  on.sensor.drift.random_walk_v_per_sqrt_hour = 0.6;
  const SimRun c = run(on);
  double ss = 0;
  std::size_t m = 0;
  for (std::size_t i = 200; i < c.scans.size(); i += 200, ++m) {
    const double d = (c.scans[i].sensor_v - a.scans[i].sensor_v) - (c.scans[i - 200].sensor_v - a.scans[i - 200].sensor_v);
    ss += d * d;
  }
  EXPECT_NEAR(std::sqrt(ss / static_cast<double>(m)), 0.6 / 60.0, 0.1 * 0.6 / 60.0);
}

TEST(SimEffect, SourcePowerStepsAreCancelledByTheReferenceUnlessCouplingIsImperfect) {
  Scenario s = clean_quasi_static();
  s.light.steps.enabled = true;
  s.light.steps.steps = {{12.0, -0.05}};  // inside the first hold (0-10 s at 0 deg... 11-21 s at 5 deg)
  const SimRun r = run(s);
  const std::size_t before = 12 * 200 - 50, after = 12 * 200 + 50;  // same hold, same angle
  ASSERT_EQ(r.scans[before].angle_true_deg, r.scans[after].angle_true_deg);
  EXPECT_NEAR(r.scans[after].sensor_v / r.scans[before].sensor_v, 0.95, 1e-6);
  EXPECT_NEAR(r.scans[after].reference_v / r.scans[before].reference_v, 0.95, 1e-6);
  auto norm = [&](const Scan& x) { return x.sensor_v * 4.0 / x.reference_v; };
  EXPECT_NEAR(norm(r.scans[after]), norm(r.scans[before]), 1e-6);
  // Imperfect cancellation: sensor ~ P^1.3 -> the normalised voltage keeps P^0.3 of the step.
  s.light.source_power_coupling.enabled = true;
  s.light.source_power_coupling.sensor_exponent = 1.3;
  s.light.source_power_coupling.reference_offset_v = 0;
  const SimRun c = run(s);
  EXPECT_NEAR(norm(c.scans[after]) / norm(c.scans[before]), std::pow(0.95, 0.3), 1e-6);
  // A dark offset on the reference photodiode: v_norm = v P L / (L P + o).
  s.light.source_power_coupling.sensor_exponent = 1.0;
  s.light.source_power_coupling.reference_offset_v = 0.05;
  const SimRun o = run(s);
  EXPECT_NEAR(norm(o.scans[after]) / norm(o.scans[before]), 0.95 * (4.0 + 0.05) / (4.0 * 0.95 + 0.05), 1e-6);
}

TEST(SimEffect, MainsInterferenceAppearsAt50HzInTheSpectrum) {
  Scenario off = clean(), on = off;
  on.daq.periodic_interference.enabled = true;
  on.daq.periodic_interference.amplitude_v = 0.003;
  on.daq.periodic_interference.frequency_hz = 50;
  on.daq.periodic_interference.phase_deg = 30;
  on.duration_s = 60;
  off.duration_s = 60;
  for (double fs : {200.0, 1000.0}) {
    const SimRun a = run(off, 1, fs), b = run(on, 1, fs);
    std::vector<double> ref(b.scans.size()), ref0(a.scans.size());
    for (std::size_t i = 0; i < ref.size(); ++i) ref[i] = b.scans[i].reference_v, ref0[i] = a.scans[i].reference_v;
    EXPECT_NEAR(amplitude_at(ref, fs, 50), 0.003, 0.003 * 0.01) << fs;
    EXPECT_LT(amplitude_at(ref0, fs, 50), 1e-6) << fs;
    EXPECT_LT(amplitude_at(ref, fs, 37), 1e-5) << fs;
  }
}

TEST(SimEffect, QuantisationStepIsTheConfiguredLsb) {
  struct Case { pof::sim::Device dev; pof::sim::Terminal term; double range; int bits; };
  for (const Case& c : {Case{pof::sim::Device::kUsb6008, pof::sim::Terminal::kDifferential, 5, 12},
                        Case{pof::sim::Device::kUsb6008, pof::sim::Terminal::kRse, 10, 11},
                        Case{pof::sim::Device::kUsb6009, pof::sim::Terminal::kDifferential, 10, 14}}) {
    Scenario s = pof::sim::builtin_scenario("paper");
    s.daq.device = c.dev;
    s.daq.terminal = c.term;
    s.daq.range_v = c.range;
    s.duration_s = 300;
    const double lsb = 2 * c.range / std::ldexp(1.0, c.bits);
    EXPECT_DOUBLE_EQ(s.daq.lsb_v(), lsb);
    const SimRun r = run(s);
    std::vector<double> v;
    for (const auto& x : r.scans) {
      const double code = (x.sensor_v + c.range) / lsb;
      ASSERT_EQ(code, std::round(code));
      v.push_back(x.sensor_v);
    }
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
    double step = 1e9;
    for (std::size_t i = 1; i < v.size(); ++i) step = std::min(step, v[i] - v[i - 1]);
    EXPECT_NEAR(step, lsb, 1e-12) << c.bits;
  }
}

TEST(SimEffect, ClippingAtTheRange) {
  Scenario s = clean_quasi_static();
  s.daq.bits = 0;  // 12-bit differential
  s.daq.range_v = 2.5;
  const SimRun r = run(s);
  const double top = 2.5 - s.daq.lsb_v();
  EXPECT_EQ(r.scans[0].sensor_v, top);       // 4.35 V at 0 deg
  EXPECT_EQ(r.scans[0].reference_v, top);    // 4.0 V
  EXPECT_EQ(r.scans[0].over_range, 0b011);
  const Scan& end = r.scans.back();          // 90 deg: 2.38 V is inside the range
  EXPECT_NEAR(end.sensor_v, pof::core::quasi_static_voltage(pof::core::paper_coefficients(), 90), s.daq.lsb_v());
  EXPECT_EQ(end.over_range & 1, 0);
  for (const auto& x : r.scans) EXPECT_LE(x.sensor_v, top);
}

TEST(SimEffect, AccelerationDependenceIsProportionalToAcceleration) {
  Scenario off = clean_cycles(), on = off;
  on.sensor.acceleration_dependence.enabled = true;
  on.sensor.acceleration_dependence.gain_v_per_rad_s2 = 0.05;
  const SimRun a = run(off), b = run(on);
  std::size_t accelerating = 0;
  for (std::size_t i = 0; i < a.scans.size(); ++i) {
    EXPECT_NEAR(b.scans[i].sensor_v - a.scans[i].sensor_v, 0.05 * a.trace[i].acceleration_rad_s2, 1e-6);
    accelerating += std::abs(a.trace[i].acceleration_rad_s2) > 1;
  }
  EXPECT_GT(accelerating, 100u);
}

TEST(SimEffect, StaticNonlinearityBowsTheQuasiStaticLine) {
  Scenario off = clean_quasi_static(), on = off;
  on.sensor.static_nonlinearity.enabled = true;
  on.sensor.static_nonlinearity.bow_v = 0.02;
  const SimRun a = run(off), b = run(on);
  const auto h = holds(a, 1900);
  EXPECT_NEAR(b.scans[h[0].first + 10].sensor_v - a.scans[h[0].first + 10].sensor_v, 0.0, 1e-6);    // 0 deg
  EXPECT_NEAR(b.scans[h[9].first + 10].sensor_v - a.scans[h[9].first + 10].sensor_v, 0.02, 1e-6);   // 45 deg
  EXPECT_NEAR(b.scans[h[18].first + 10].sensor_v - a.scans[h[18].first + 10].sensor_v, 0.0, 1e-6);  // 90 deg
}

TEST(SimEffect, RateDependentHysteresisOpensWithVelocity) {
  Scenario off = clean_cycles(), on = off;
  on.sensor.rate_dependent_hysteresis.enabled = true;
  on.sensor.rate_dependent_hysteresis.amplitude_v = 0.03;
  on.sensor.rate_dependent_hysteresis.velocity_scale_rad_s = 0.1;
  const SimRun a = run(off), b = run(on);
  for (std::size_t i = 0; i < a.scans.size(); ++i) {
    const double w = a.trace[i].velocity_rad_s, th = a.scans[i].angle_true_deg;
    const double d = b.scans[i].sensor_v - a.scans[i].sensor_v;
    if (std::abs(w) < 0.01) {
      ASSERT_NEAR(d, 0, 1e-6);
      continue;
    }
    const double want = (w > 0 ? 1 : -1) * 0.03 * (1 - std::exp(-std::abs(w) / 0.1)) * std::sin(std::numbers::pi * th / 90);
    ASSERT_NEAR(d, want, 1e-6);
  }
}

TEST(SimEffect, MultiplexedChannelsAreNotSimultaneous) {
  Scenario s = clean_cycles();
  s.daq.multiplexed = true;
  s.daq.convert_interval_s = 1e-4;  // the pot is the third channel: 200 us after the sensor
  const SimRun r = run(s);
  std::size_t n = 0;
  for (std::size_t i = 1; i < r.scans.size(); ++i) {
    const double w = r.trace[i].velocity_rad_s;
    if (std::abs(std::abs(w) - 0.4304) > 1e-12 || r.trace[i - 1].velocity_rad_s != w) continue;
    EXPECT_NEAR(r.scans[i].angle_ref_deg - r.scans[i].angle_true_deg, w * 180 / std::numbers::pi * 2e-4, 1e-5);
    ++n;
  }
  EXPECT_GT(n, 100u);
}

TEST(SimEffect, PotentiometerLinearityAndVibrationNear90) {
  Scenario off = clean_quasi_static(), on = off;
  on.knee.potentiometer.linearity.enabled = true;
  on.knee.potentiometer.linearity.error_pct = 2.0;
  on.knee.potentiometer.linearity.shape = pof::sim::LinearityShape::kBow;
  const SimRun a = run(off), b = run(on);
  const auto h = holds(a, 1900);
  EXPECT_NEAR(b.scans[h[9].first].angle_ref_deg - b.scans[h[9].first].angle_true_deg, 1.8, 1e-4);  // 2 % of 90 deg at 45 deg
  EXPECT_NEAR(b.scans[h[18].first].angle_ref_deg - 90, 0, 1e-4);

  on = off;
  on.knee.vibration.enabled = true;
  on.knee.vibration.amplitude_deg = 0.3;
  on.knee.vibration.frequency_hz = 12;
  on.knee.vibration.onset_deg = 75;
  const SimRun v = run(on);
  auto pot_amp = [&](std::size_t k) {
    std::vector<double> x;
    for (std::size_t i = h[k].first; i < h[k].first + 1800; ++i) x.push_back(v.scans[i].angle_ref_deg);
    return amplitude_at(x, 200, 12);
  };
  EXPECT_NEAR(pot_amp(18), 0.3, 0.01);  // 90 deg: full amplitude
  EXPECT_NEAR(pot_amp(17), 0.2, 0.01);  // 85 deg: ramp from 75 deg
  EXPECT_LT(pot_amp(9), 1e-6);          // 45 deg: none
  for (std::size_t i = 0; i < v.scans.size(); ++i) EXPECT_EQ(v.scans[i].angle_true_deg, a.scans[i].angle_true_deg);
}

TEST(SimEffect, SourceWanderIsAnOrnsteinUhlenbeckProcess) {
  Scenario s = clean_quasi_static();
  s.light.wander.enabled = true;
  s.light.wander.sigma_rel = 0.02;
  s.light.wander.tau_s = 2.0;
  const SimRun r = run(s);
  double sum = 0, ss = 0;
  for (const auto& t : r.trace) sum += t.source_power_rel - 1, ss += (t.source_power_rel - 1) * (t.source_power_rel - 1);
  const double n = static_cast<double>(r.trace.size());
  EXPECT_NEAR(std::sqrt(ss / n - (sum / n) * (sum / n)), 0.02, 0.004);
  // Cancelled by the reference (constant source coupling): normalised voltage unaffected.
  Scenario off = clean_quasi_static();
  const SimRun a = run(off);
  for (std::size_t i = 0; i < a.scans.size(); i += 11)
    EXPECT_NEAR(r.scans[i].sensor_v * 4.0 / r.scans[i].reference_v, a.scans[i].sensor_v, 1e-5);
}

}  // namespace
