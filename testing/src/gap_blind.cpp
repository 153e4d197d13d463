// The blind test harness (see blind.hpp).
#include "pof/testing/gap_blind.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

#include "pof/gap/io.hpp"
#include "pof/io/csv_writer.hpp"
#include "pof/io/recording_reader.hpp"
#include "pof/sim/effects.hpp"
#include "pof/sim/simulator.hpp"

namespace pof::gap::blind {

using nlohmann::json;

sim::Scenario base_scenario(bool short_session) {
  sim::Scenario s = sim::builtin_scenario("paper");
  sim::disable_all_effects(s);
  s.name = short_session ? "blind-short" : "blind";
  s.light.wander = {true, 0.01, 60.0};
  s.light.steps.enabled = true;
  s.light.steps.steps = {{short_session ? 100.0 : 300.0, -0.03}, {short_session ? 200.0 : 700.0, 0.02}};
  s.trajectory.clear();
  sim::Segment qs;
  qs.kind = sim::SegmentKind::kQuasiStatic;
  qs.label = "quasi_static";
  qs.step_deg = short_session ? 15.0 : 5.0;
  qs.descending = true;  // holds after extension too: creep and backlash show with both signs
  s.trajectory.push_back(qs);
  sim::Segment cy;
  cy.kind = sim::SegmentKind::kCycles;
  cy.label = short_session ? "cycles" : "table1";
  if (short_session) cy.velocities_rad_s = {0.0898, 0.1726, 0.3415, 0.4304};
  else cy.velocities_rad_s.assign(sim::kTable1Velocities.begin(), sim::kTable1Velocities.end());
  cy.pause_s = 2.0;
  s.trajectory.push_back(cy);
  sim::Segment g;
  g.kind = sim::SegmentKind::kGait;
  g.label = "gait";
  g.min_deg = 5;
  g.max_deg = 60;
  g.cycles = short_session ? 6 : 12;
  g.period_s = 5;
  s.trajectory.push_back(g);
  sim::Segment h;
  h.kind = sim::SegmentKind::kHold;
  h.label = "hold";
  h.has_angle = true;
  h.angle_deg = 0;
  h.duration_s = 10;
  s.trajectory.push_back(h);
  sim::validate(s);
  return s;
}

Hidden hide(sim::Scenario& s, const std::string& e, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  auto in = [&](double a, double b) { return a + (b - a) * u(rng); };
  auto sign = [&] { return u(rng) < 0.5 ? -1.0 : 1.0; };
  Hidden h;
  h.effect = e;
  bool* sw = sim::effect_switch(s, e);
  if (sw == nullptr) throw std::invalid_argument("blind: unknown effect '" + e + "'");
  *sw = true;
  if (e == "static_nonlinearity") {
    auto& p = s.sensor.static_nonlinearity;
    p.bow_v = sign() * in(0.01, 0.03);
    p.s_v = sign() * in(0.0, 0.5) * std::abs(p.bow_v);
    h.truth = {{"bow_v", p.bow_v}, {"s_v", p.s_v}};
  } else if (e == "drift") {
    auto& p = s.sensor.drift;
    p.rate_v_per_hour = sign() * in(0.04, 0.15);
    p.random_walk_v_per_sqrt_hour = 0;
    h.truth = {{"rate_v_per_hour", p.rate_v_per_hour}};
  } else if (e == "creep") {
    auto& p = s.sensor.creep;
    p.terms = {sim::CreepTerm{in(2.0, 10.0), -in(0.0006, 0.002)}};
    h.truth = {{"tau_s", p.terms[0].tau_s}, {"gain_v_per_deg", p.terms[0].gain_v_per_deg}};
  } else if (e == "rate_dependent_hysteresis") {
    auto& p = s.sensor.rate_dependent_hysteresis;
    p.amplitude_v = sign() * in(0.008, 0.03);
    p.velocity_scale_rad_s = in(0.05, 0.2);
    h.truth = {{"amplitude_v", p.amplitude_v}, {"velocity_scale_rad_s", p.velocity_scale_rad_s}};
  } else if (e == "acceleration_dependence") {
    auto& p = s.sensor.acceleration_dependence;
    p.gain_v_per_rad_s2 = sign() * in(0.005, 0.02);
    h.truth = {{"gain_v_per_rad_s2", p.gain_v_per_rad_s2}};
  } else if (e == "time_delay") {
    auto& p = s.daq.time_delay;
    p.channel = sim::Channel::kSensor;
    p.delay_s = in(0.01, 0.06);
    h.truth = {{"delay_s", p.delay_s}};
  } else if (e == "backlash") {
    auto& p = s.knee.backlash;
    p.width_deg = in(0.5, 2.0);
    h.truth = {{"width_deg", p.width_deg}};
  } else if (e == "source_power_coupling") {
    auto& p = s.light.source_power_coupling;
    p.sensor_exponent = 1.0 + sign() * in(0.1, 0.4);
    p.reference_offset_v = in(0.0, 0.05);
    h.truth = {{"sensor_exponent", p.sensor_exponent}, {"reference_offset_v", p.reference_offset_v}};
  } else if (e == "periodic_interference") {
    auto& p = s.daq.periodic_interference;
    p.frequency_hz = u(rng) < 0.5 ? 50.0 : 60.0;
    p.amplitude_v = in(0.0045, 0.015);  // RMS >= 1.5x the 2.1 mV noise floor
    p.phase_deg = in(0, 360);
    p.third_harmonic_rel = 0;
    h.truth = {{"frequency_hz", p.frequency_hz}, {"amplitude_v", p.amplitude_v}};
  }
  return h;
}

std::vector<Hidden> hide_random(sim::Scenario& s, int count, std::mt19937_64& rng) {
  std::vector<std::string> ids(sim::kGapEffectIds.begin(), sim::kGapEffectIds.end());
  std::shuffle(ids.begin(), ids.end(), rng);
  std::vector<Hidden> out;
  for (int i = 0; i < count && i < static_cast<int>(ids.size()); ++i) out.push_back(hide(s, ids[static_cast<std::size_t>(i)], rng));
  return out;
}

io::Recording simulate(const sim::Scenario& s, std::uint64_t seed) {
  sim::Simulator simu(s, seed, 0);
  std::vector<sim::Scan> all;
  std::array<sim::Scan, 1024> buf{};
  for (std::size_t n = simu.next(buf); n > 0; n = simu.next(buf)) all.insert(all.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
  io::Recording r;
  r.source = "sim:" + s.name;
  const auto n = static_cast<Eigen::Index>(all.size());
  r.t_s.resize(n);
  r.sensor_v.resize(n);
  r.reference_v.resize(n);
  r.angle_ref_deg.resize(n);
  r.angle_true_deg.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& sc = all[static_cast<std::size_t>(i)];
    r.t_s(i) = sc.t_s;
    r.sensor_v(i) = sc.sensor_v;
    r.reference_v(i) = sc.reference_v;
    r.angle_ref_deg(i) = sc.angle_ref_deg;
    r.angle_true_deg(i) = sc.angle_true_deg;
  }
  return r;
}

bool Trial::correct() const { return hits() == static_cast<int>(hidden.size()) && false_finds() == 0; }

int Trial::hits() const {
  int n = 0;
  for (const auto& h : hidden) n += std::count(found.begin(), found.end(), h.effect) > 0 ? 1 : 0;
  return n;
}

int Trial::false_finds() const {
  int n = 0;
  for (const auto& f : found)
    n += std::none_of(hidden.begin(), hidden.end(), [&](const Hidden& h) { return h.effect == f; }) ? 1 : 0;
  return n;
}

Trial run_trial(std::uint64_t seed, int count, bool short_session, const std::filesystem::path& dir, const Options& opt) {
  Trial t;
  t.seed = seed;
  std::mt19937_64 rng(seed);
  sim::Scenario s = base_scenario(short_session);
  t.hidden = hide_random(s, count, rng);
  t.csv = (dir / ("blind_" + std::to_string(seed) + ".csv")).string();
  io::write_csv(t.csv, simulate(s, seed));
  // From here on only the file: nothing of the draw reaches the workflow.
  const auto t0 = std::chrono::steady_clock::now();
  const Result r = analyse(io::read_csv(t.csv), opt);
  t.analysis_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const auto& st : r.steps) t.found.push_back(st.effect);
  t.baseline_gap_deg = r.baseline_gap_deg;
  t.final_gap_deg = r.final_gap_deg;
  t.gap = r.to_json();
  return t;
}

}  // namespace pof::gap::blind
