#pragma once
// The calibrated sensor model of Leal-Junior et al. 2017 (Meas. Sci. Technol. 28 125103), table 2:
//
//   f1  h    = c1 exp(c2 w)                hysteresis [%] against angular velocity w [rad/s]
//   f2  a_x  = c3 h + c4,  b_x = c5 h + c6  per direction x (f = flexion, e = extension)
//   f3  V1   = a_x Vmeas + b_x              hysteresis-compensated voltage
//   f4  V2   = c7 V1 - c8                   correction of the ends of the cycle (per direction)
//   f5  alpha = -c9 V2 + c10                quasi-static line, angle [deg]
//
// Vmeas is the reference-normalised sensor voltage [V] (see normalisation in the calibration
// notes). Combined, alpha is linear in Vmeas with coefficients linear in e = exp(c2 w):
//   alpha = (A1 e + A0) Vmeas + B1 e + B0                              eq. (11) / (12)
// Pure header-level arithmetic: no allocation, no I/O; safe in the per-scan path.
#include <cmath>

namespace pof::core {

enum class Direction : int { kHold = 0, kFlexion = 1, kExtension = 2 };

/// c3..c8 of table 2 for one movement direction.
struct DirectionCoefficients {
  double c3 = 0, c4 = 1;  // a_x = c3 h + c4   [1/%], [-]
  double c5 = 0, c6 = 0;  // b_x = c5 h + c6   [V/%], [V]
  double c7 = 1, c8 = 0;  // V2 = c7 V1 - c8   [-], [V]
};

/// The coefficients c1..c10 of table 2. Units: c1 [%], c2 [s/rad], c9 [deg/V], c10 [deg].
struct ModelCoefficients {
  double c1 = 0, c2 = 0;
  DirectionCoefficients flexion, extension;
  double c9 = 1, c10 = 0;

  [[nodiscard]] const DirectionCoefficients& of(Direction d) const {
    return d == Direction::kExtension ? extension : flexion;
  }
};

/// Table 2 / eqs. (2)-(10) as printed in the paper.
inline ModelCoefficients paper_coefficients() {
  ModelCoefficients m;
  m.c1 = 2.641;
  m.c2 = -3.494;
  m.flexion = {0.009552, 0.9256, -0.0443, 0.3614, 1.091, 0.4075};
  m.extension = {0.01067, 0.9141, -0.04147, 0.4104, 1.079, 0.3624};
  m.c9 = 45.6621;
  m.c10 = 198.67;
  return m;
}

/// eq. (11)/(12) in the paper's printed form: alpha = (a1 e + a0) V + b1 e + b0, e = exp(c2 w).
struct CombinedEquation {
  double a1 = 0, a0 = 0, b1 = 0, b0 = 0, c2 = 0;

  [[nodiscard]] double angle(double v_meas, double w) const {
    const double e = std::exp(c2 * w);
    return (a1 * e + a0) * v_meas + b1 * e + b0;
  }
};

/// f1: hysteresis [%] at angular velocity |w| [rad/s].
inline double hysteresis_pct(const ModelCoefficients& m, double w) { return m.c1 * std::exp(m.c2 * std::abs(w)); }

/// f5 alone: the quasi-static angle [deg] of a normalised voltage (used in holds and uncompensated).
inline double quasi_static_angle(const ModelCoefficients& m, double v) { return -m.c9 * v + m.c10; }

/// Inverse of f5: the normalised voltage [V] the quasi-static line gives at angle [deg].
inline double quasi_static_voltage(const ModelCoefficients& m, double angle_deg) { return (m.c10 - angle_deg) / m.c9; }

/// f2 at |w|: f3's gain a = c3 h + c4 and offset b = c5 h + c6 for direction x, h = f1(|w|).
struct F3Line {
  double a, b;
};
inline F3Line f3_line(const ModelCoefficients& m, const DirectionCoefficients& x, double w) {
  const double h = hysteresis_pct(m, w);
  return {x.c3 * h + x.c4, x.c5 * h + x.c6};
}

/// f1..f5 chained: the compensated angle [deg] of a normalised voltage [V] measured while moving in
/// direction d (flexion or extension) at angular speed |w| [rad/s]. For kHold returns f5 alone.
inline double compensated_angle(const ModelCoefficients& m, double v_meas, double w, Direction d) {
  if (d == Direction::kHold) return quasi_static_angle(m, v_meas);
  const DirectionCoefficients& x = m.of(d);
  const F3Line f3 = f3_line(m, x, w);
  const double v1 = f3.a * v_meas + f3.b;  // f3
  const double v2 = x.c7 * v1 - x.c8;      // f4
  return quasi_static_angle(m, v2);        // f5
}

/// Inverse of compensated_angle in v_meas: the voltage [V] the model predicts at angle [deg] while
/// moving in d at |w|. This is the forward sensor model the simulator and `pof gap` run.
inline double model_voltage(const ModelCoefficients& m, double angle_deg, double w, Direction d) {
  if (d == Direction::kHold) return quasi_static_voltage(m, angle_deg);
  const DirectionCoefficients& x = m.of(d);
  const F3Line f3 = f3_line(m, x, w);
  const double v2 = quasi_static_voltage(m, angle_deg);
  const double v1 = (v2 + x.c8) / x.c7;
  return (v1 - f3.b) / f3.a;
}

/// The combined equation (11) (flexion) or (12) (extension) in the paper's printed form.
inline CombinedEquation combined_equation(const ModelCoefficients& m, Direction d) {
  const DirectionCoefficients& x = m.of(d);
  const double k = -m.c9 * x.c7;  // d alpha / d V1
  CombinedEquation eq;
  eq.c2 = m.c2;
  eq.a1 = k * x.c3 * m.c1;
  eq.a0 = k * x.c4;
  eq.b1 = k * x.c5 * m.c1;
  eq.b0 = k * x.c6 + m.c9 * x.c8 + m.c10;
  return eq;
}

}  // namespace pof::core
