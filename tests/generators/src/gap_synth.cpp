// Synthetic recordings with hidden effects (see synth.hpp). The physical form of each injected effect
// is written independently of the candidate terms in analysis.cpp where it can be (play operator for
// backlash, delayed voltage for time_delay, c1 scaling for rate-dependent hysteresis, power ratio for
// the source coupling), so a test is not just the fit reproducing its own columns.
#include "pof/testing/gap_synth.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include "pof/core/effects.hpp"
#include "pof/core/model.hpp"
#include "pof/core/paper_protocol.hpp"
#include "pof/core/units.hpp"
#include "pof/base/errors.hpp"

namespace pof::gap {

namespace {

using pof::core::kRadPerDeg;

// The exoskeleton: velocity-limited, acceleration-limited moves (harmonic drive + DC motor).
struct Knee {
  double dt = 0.005, acc_max = 1.0;  // s, rad/s^2
  std::vector<double> angle;  // true joint angle [deg]
  double a = 0, w = 0;        // deg, rad/s

  void hold(double s) {
    const auto n = static_cast<long>(std::lround(s / dt));
    for (long i = 0; i < n; ++i) angle.push_back(a);
  }
  void move_to(double target, double wmax) {
    for (int guard = 0; guard < 10'000'000; ++guard) {
      const double dist = (target - a) * kRadPerDeg;
      if (std::abs(dist) < 1e-6 && std::abs(w) < 1e-6) break;
      const double vdes = std::copysign(std::min(wmax, std::sqrt(2 * acc_max * std::abs(dist))), dist);
      w += std::clamp(vdes - w, -acc_max * dt, acc_max * dt);
      double na = a + w * dt / kRadPerDeg;
      if ((target - a) * (target - na) <= 0) { na = target; w = 0; }
      a = na;
      angle.push_back(a);
    }
  }
};

}  // namespace

io::Recording synthesise(const SynthConfig& cfg, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double dt = 1.0 / cfg.rate_hz;
  Knee k;
  k.dt = dt;
  // Calibration protocol (the paper, section 2.2): quasi-static steps with 10 s holds, up and back down, then
  // constant-velocity flexion/extension cycles at the table-1 velocities.
  k.hold(10);
  const double step = cfg.short_protocol ? 15.0 : 5.0;
  for (double a = step; a <= 90.0 + 1e-9; a += step) { k.move_to(a, 0.2); k.hold(10); }
  for (double a = 90.0 - step; a >= -1e-9; a -= step) { k.move_to(a, 0.2); k.hold(10); }
  const std::vector<double> full(core::kTable1Velocities.begin(), core::kTable1Velocities.end());
  const std::vector<double> fast{0.0898, 0.1726, 0.3415, 0.4304};
  for (double w : cfg.short_protocol ? fast : full)
    for (int c = 0; c < cfg.cycles_per_velocity; ++c) { k.move_to(90, w); k.hold(3); k.move_to(0, w); k.hold(3); }
  if (cfg.extra_seconds > 0) {
    // Gait-like: 10-80 deg with a slowly varying cadence (0.35-0.65 Hz): the paper's future work.
    k.move_to(10, 0.3);
    double ph = 0;
    const auto n = static_cast<long>(cfg.extra_seconds / dt);
    std::uniform_real_distribution<double> u(0, 2 * std::numbers::pi);
    const double p0 = u(rng);
    for (long i = 0; i < n; ++i) {
      const double t = static_cast<double>(i) * dt;
      ph += 2 * std::numbers::pi * (0.5 + 0.15 * std::sin(0.05 * t + p0)) * dt;
      k.angle.push_back(45.0 - 35.0 * std::cos(ph));
    }
    k.a = k.angle.back();
    k.w = 0;
    k.move_to(0, 0.3);
    k.hold(5);
  }
  const auto n = static_cast<Eigen::Index>(k.angle.size());
  const double T = static_cast<double>(n) * dt;
  auto eff = [&](const char* name) {
    const auto it = cfg.effects.find(name);
    return it == cfg.effects.end() ? 0.0 : it->second;
  };
  for (const auto& [name, mag] : cfg.effects) {
    if (!core::effect_of(name))
      throw pof::ConfigError("synthesise: unknown effect '" + name + "'");
    (void)mag;
  }

  Eigen::VectorXd ang = Eigen::Map<Eigen::VectorXd>(k.angle.data(), n);
  // True kinematics (exact derivatives of the commanded trajectory).
  Eigen::VectorXd w(n), acc(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index a = std::max<Eigen::Index>(0, i - 1), b = std::min(n - 1, i + 1);
    w(i) = (ang(b) - ang(a)) * kRadPerDeg / (static_cast<double>(b - a) * dt);
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index a = std::max<Eigen::Index>(0, i - 5), b = std::min(n - 1, i + 5);
    acc(i) = (w(b) - w(a)) / (static_cast<double>(b - a) * dt);
  }

  const core::ModelCoefficients& m = cfg.model;
  const double rdh = eff("rate_dependent_hysteresis");
  const double creep_g = eff("creep"), tau = cfg.creep_tau_s, acc_g = eff("acceleration_dependence");
  const double k2 = eff("static_nonlinearity");
  double x = ang(0);
  const double ca = 1.0 - std::exp(-dt / tau);
  // Relaxation over two time constants a decade and more apart (1.5 s and 40 s, half the gain
  // each), integrated with the trapezoidal rule (not the exact exponential step `pof gap` uses).
  const double relax_g = eff("viscoelastic_relaxation");
  const std::array<double, 2> relax_tau{1.5, 40.0};
  std::array<double, 2> rx{ang(0), ang(0)};
  // Rate-independent hysteresis with memory as an exponential-approach hysteron: every degree of
  // movement pulls the state 1/(5 deg) of the way towards +-A in the direction of movement, so it
  // keeps its value through holds and a short reversal only partly reverses it (minor loops).
  const double mem_a = eff("memory_hysteresis");
  double z = 0;
  Eigen::VectorXd v(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    x += ca * (ang(i) - x);
    double relax = 0;
    for (std::size_t j = 0; j < rx.size(); ++j) {
      const double prev = i > 0 ? ang(i - 1) : ang(0);
      rx[j] += dt / (relax_tau[j] + dt / 2) * ((ang(i) + prev) / 2 - rx[j]);
      relax += 0.5 * relax_g * (rx[j] - ang(i));
    }
    if (i > 0) {
      const double d = ang(i) - ang(i - 1);
      if (d != 0) z += (std::copysign(mem_a, d) - z) * (1.0 - std::exp(-std::abs(d) / 5.0));
    }
    const double u = pof::core::static_nonlinearity_u(ang(i));
    // The angle the fibre "sees": viscoelastic memory, static nonlinearity, acceleration term.
    const double seen = ang(i) + creep_g * (x - ang(i)) + relax + k2 * (u * u + 0.5 * u * u * u) + acc_g * acc(i);
    const double aw = std::abs(w(i));
    const core::Direction d = aw < 0.01 ? core::Direction::kHold : (w(i) > 0 ? core::Direction::kFlexion : core::Direction::kExtension);
    v(i) = core::model_voltage(m, seen, aw, d) + z;
    // Hysteresis opening with velocity, largest mid-range (0.1 rad/s velocity scale).
    if (d != core::Direction::kHold)
      v(i) += (w(i) > 0 ? rdh : -rdh) * (1.0 - std::exp(-aw / 0.1)) * std::sin(std::numbers::pi * ang(i) / 90.0);
  }
  if (const double d = eff("time_delay"); d != 0) {  // the sensor channel lags the reference by d
    Eigen::VectorXd vd(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double xi = std::clamp(static_cast<double>(i) - d / dt, 0.0, static_cast<double>(n - 1));
      const auto i0 = static_cast<Eigen::Index>(std::floor(xi));
      const Eigen::Index i1 = std::min(i0 + 1, n - 1);
      vd(i) = v(i0) + (xi - static_cast<double>(i0)) * (v(i1) - v(i0));
    }
    v = vd;
  }
  const double drift = eff("drift");
  const double gamma = eff("source_power_coupling");
  const double amp = eff("periodic_interference");
  std::uniform_real_distribution<double> uphase(0, 2 * std::numbers::pi);
  const double phase = uphase(rng);
  // Light-source power: slow wander (smoothed random walk) plus occasional steps.
  double pw = 0, pwf = 0, steps = 0;
  std::uniform_real_distribution<double> u01(0, 1);
  io::Recording rec;
  rec.source = "synthetic";
  rec.t_s.resize(n);
  rec.sensor_v.resize(n);
  rec.reference_v.resize(n);
  rec.angle_ref_deg.resize(n);
  rec.angle_true_deg = ang;
  const double b = eff("backlash");
  double pot = ang(0);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) * dt;
    // Ornstein-Uhlenbeck wander (60 s correlation time, RMS reference_wander), smoothed over 5 s.
    pw += -pw * dt / 60.0 + cfg.reference_wander * std::sqrt(2.0 / 60.0 * dt) * gauss(rng);
    pwf += (pw - pwf) * (dt / 5.0);
    if (cfg.reference_wander > 0 && u01(rng) < dt / 120.0) steps += (u01(rng) - 0.5) * cfg.reference_wander;
    const double dP = cfg.reference_wander > 0 ? std::clamp(pwf + steps, -0.3, 0.3) : 0.0;
    double sv = v(i) * (1.0 + dP) * (1.0 + gamma * dP);
    sv += -drift * (t / T) / m.c9 + amp * std::sin(2 * std::numbers::pi * cfg.interference_hz * t + phase);
    sv += cfg.noise_v * gauss(rng);
    // Belt backlash: the potentiometer only follows once the dead band b is taken up (play operator).
    if (ang(i) - pot > b / 2) pot = ang(i) - b / 2;
    if (ang(i) - pot < -b / 2) pot = ang(i) + b / 2;
    rec.t_s(i) = t;
    rec.sensor_v(i) = sv;
    rec.reference_v(i) = cfg.reference_level_v * (1.0 + dP);
    rec.angle_ref_deg(i) = pot + cfg.pot_noise_deg * gauss(rng);
  }
  return rec;
}

double draw_magnitude(const std::string& name, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  const double sign = u(rng) < 0.5 ? -1.0 : 1.0;
  auto in = [&](double a, double b) { return a + (b - a) * u(rng); };
  if (name == "static_nonlinearity") return sign * in(0.5, 2.0);        // deg at the range ends
  if (name == "drift") return sign * in(0.5, 2.0);                      // deg over the recording
  if (name == "creep") return in(0.03, 0.10);                           // relaxation gain
  if (name == "rate_dependent_hysteresis") return sign * in(0.008, 0.03);  // V at mid-range
  if (name == "acceleration_dependence") return sign * in(0.3, 1.0);    // deg per rad/s^2
  if (name == "time_delay") return in(0.010, 0.060);                    // s
  if (name == "backlash") return in(0.5, 2.0);                          // deg
  if (name == "source_power_coupling") return sign * in(0.1, 0.4);      // uncancelled fraction
  if (name == "periodic_interference") return in(0.004, 0.012);         // V at 50 Hz
  if (name == "memory_hysteresis") return sign * in(0.008, 0.025);      // V half-height
  if (name == "viscoelastic_relaxation") return in(0.04, 0.10);         // total relaxation gain
  return 0.0;
}

}  // namespace pof::gap
