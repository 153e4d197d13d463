#pragma once
// Test-support generator: a paper-like calibration recording made from the model itself
// (model_voltage, the inverse of eq. (11)/(12)), acquired like a USB-6008 would: 200 Hz, Gaussian
// noise, 12-bit quantisation over +-10 V. Not the physics simulator (daq/sim/); just enough to check
// that the calibration fits give back the equations the data came from.
//
// Protocol (Leal-Junior et al. 2017, section 2.2 and table 1): quasi-static 0 -> 90 deg in 5 deg
// steps with 10 s holds, back to 0, then flexion/extension cycles 0 -> 90 -> 0 deg at constant
// angular velocity for each velocity of table 1 (0.0898 for test 5), with a short pause at each
// reversal.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "pof/core/model.hpp"
#include "pof/core/paper_protocol.hpp"

namespace pof::testing {

struct Usb6008 {
  double range_v = 10.0;   // +-10 V
  int bits = 12;
  double noise_v = 0.0015; // rms input noise [V]

  [[nodiscard]] double lsb() const { return 2 * range_v / std::ldexp(1.0, bits); }
  [[nodiscard]] double acquire(double v, std::mt19937_64& rng) const {
    std::normal_distribution<double> n(0.0, noise_v);
    double x = noise_v > 0 ? v + n(rng) : v;
    if (bits > 0) x = std::round((x + range_v) / lsb()) * lsb() - range_v;
    return std::clamp(x, -range_v, range_v);
  }
};

struct ProtocolSettings {
  double rate_hz = 200;
  std::vector<double> velocities_rad_s = {pof::core::kTable1Velocities.begin(), pof::core::kTable1Velocities.end()};
  int cycles_per_velocity = 1;
  double angle_lo = 0, angle_hi = 90;
  bool quasi_static = true;
  double step_deg = 5, hold_s = 10, step_speed_deg_s = 5;
  double return_speed_deg_s = 15;      // quasi-static test back to 0 (0.26 rad/s, no table-1 speed)
  double reversal_pause_s = 1.0;
  double accel_s = 0.2;                 // constant-acceleration ramp at each start/stop
  double reference_level_v = 4.0;
  double laser_drift = 0.02;            // slow relative drift of the laser power (cancelled by normalisation)
  double deg_per_volt = 18.0;           // potentiometer: 0..5 V over 0..90 deg
  Usb6008 daq;
  std::uint64_t seed = 1;
};

struct Generated {
  Eigen::VectorXd t_s, sensor_v, reference_v, angle_ref_deg, pot_v, angle_true_deg;
  [[nodiscard]] Eigen::Index size() const { return t_s.size(); }
};

/// Angle trajectory: a list of moves (constant-speed ramps with accelerations) and holds.
class Trajectory {
 public:
  explicit Trajectory(double rate_hz, double start_deg) : dt_(1.0 / rate_hz), angle_(start_deg) {}
  void hold(double seconds) {
    for (double t = 0; t < seconds - 1e-9; t += dt_) push(0.0);
  }
  /// Trapezoidal velocity profile: constant acceleration for accel_s, cruise, symmetric braking
  /// (triangular when the move is too short to reach the speed).
  void move_to(double target, double speed_deg_s, double accel_s) {
    const double d = std::abs(target - angle_);
    const double sgn = target >= angle_ ? 1 : -1;
    if (d <= 0) return;
    const double acc = speed_deg_s / accel_s;
    double vp = speed_deg_s, ta = accel_s;
    if (d < vp * ta) {
      vp = std::sqrt(d * acc);
      ta = vp / acc;
    }
    const double tc = (d - vp * ta) / vp;
    const double total = 2 * ta + tc;
    const double start = angle_;
    auto pos = [&](double t) {
      if (t <= ta) return 0.5 * acc * t * t;
      if (t <= ta + tc) return 0.5 * vp * ta + vp * (t - ta);
      const double r = total - t;
      return d - 0.5 * acc * r * r;
    };
    for (double t = dt_; t < total + dt_ - 1e-12; t += dt_) {
      const double tt = std::min(t, total);
      const double prev = angle_;
      angle_ = start + sgn * pos(tt);
      angle.push_back(angle_);
      velocity_deg_s.push_back((angle_ - prev) / dt_);
    }
  }
  std::vector<double> angle, velocity_deg_s;

 private:
  void push(double vel) {
    angle_ += vel * dt_;
    angle.push_back(angle_);
    velocity_deg_s.push_back(vel);
  }
  double dt_, angle_;
};

inline Trajectory paper_trajectory(const ProtocolSettings& p) {
  Trajectory tr(p.rate_hz, p.angle_lo);
  if (p.quasi_static) {
    tr.hold(p.hold_s);
    for (double a = p.angle_lo + p.step_deg; a <= p.angle_hi + 1e-9; a += p.step_deg) {
      tr.move_to(a, p.step_speed_deg_s, p.accel_s);
      tr.hold(p.hold_s);
    }
    tr.move_to(p.angle_lo, p.return_speed_deg_s, p.accel_s);
    tr.hold(p.hold_s);
  }
  for (const double w : p.velocities_rad_s) {
    const double speed = w * 180.0 / std::numbers::pi;
    for (int c = 0; c < p.cycles_per_velocity; ++c) {
      tr.move_to(p.angle_hi, speed, p.accel_s);
      tr.hold(p.reversal_pause_s);
      tr.move_to(p.angle_lo, speed, p.accel_s);
      tr.hold(p.reversal_pause_s);
    }
  }
  return tr;
}

/// Acquires a trajectory through the model: the sensor follows eq. (11)/(12) inverted at the
/// instantaneous |w| and direction, f5 in holds.
inline Generated acquire(const pof::core::ModelCoefficients& m, const Trajectory& tr, const ProtocolSettings& p) {
  std::mt19937_64 rng(p.seed);
  const auto n = static_cast<Eigen::Index>(tr.angle.size());
  Generated g;
  g.t_s.resize(n);
  g.sensor_v.resize(n);
  g.reference_v.resize(n);
  g.angle_ref_deg.resize(n);
  g.pot_v.resize(n);
  g.angle_true_deg.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double t = static_cast<double>(i) / p.rate_hz;
    const double a = tr.angle[k];
    const double vel = tr.velocity_deg_s[k];
    const auto dir = vel > 0 ? pof::core::Direction::kFlexion
                     : vel < 0 ? pof::core::Direction::kExtension
                               : pof::core::Direction::kHold;
    const double w = std::abs(vel) * std::numbers::pi / 180.0;
    const double gain = 1.0 + p.laser_drift * std::sin(2 * std::numbers::pi * t / 300.0);
    const double v = pof::core::model_voltage(m, a, w, dir);
    g.t_s(i) = t;
    g.angle_true_deg(i) = a;
    g.sensor_v(i) = p.daq.acquire(v * gain, rng);
    g.reference_v(i) = p.daq.acquire(p.reference_level_v * gain, rng);
    g.pot_v(i) = p.daq.acquire(a / p.deg_per_volt, rng);
    g.angle_ref_deg(i) = g.pot_v(i) * p.deg_per_volt;
  }
  return g;
}

inline Generated paper_recording(const ProtocolSettings& p = {}) {
  return acquire(pof::core::paper_coefficients(), paper_trajectory(p), p);
}

}  // namespace pof::testing
