#pragma once
// Light-source compensation (Leal-Junior et al. 2017, section 2.1): the sensor fibre's power is
// normalised by the reference fibre's, v = sensor_v * (reference_level_v / reference_v), where
// reference_level_v is the reference voltage at calibration time. With a constant reference at its
// calibrated level v == sensor_v, so the model's voltages keep their calibrated scale.
//
// Guard: a reference near zero (laser off, reference fibre unplugged) or far from its calibrated
// level is a fault, never a division by ~0. The ratio band is wide because the laser's power drifts
// and normalisation exists to absorb exactly that drift; what it cannot absorb is a reference that
// no longer sees the same source.
#include <algorithm>
#include <cmath>

#include <Eigen/Core>

namespace pof::core {

struct ReferenceGuard {
  double level_v = 1.0;       // reference voltage at calibration time [V]
  double min_ratio = 0.5;     // reference_v / level_v below this: reference lost
  double max_ratio = 2.0;     // ... above this: reference lost (wrong fibre, saturation)
  double min_abs_v = 0.05;    // absolute floor [V], whatever the level
};

struct Normalised {
  double v = std::nan("");    // normalised sensor voltage [V]; NaN when !ok
  bool ok = false;            // false: reference lost or input not finite
  bool finite_input = false;  // false: sensor_v or reference_v is NaN/inf
};

/// One scan; allocation-free, never divides by a reference below the guard.
inline Normalised normalise(double sensor_v, double reference_v, const ReferenceGuard& g) {
  Normalised n;
  n.finite_input = std::isfinite(sensor_v) && std::isfinite(reference_v);
  if (!n.finite_input) return n;
  const double floor_v = std::max(g.min_abs_v, g.min_ratio * g.level_v);
  if (!(reference_v >= floor_v) || !(reference_v <= g.max_ratio * g.level_v)) return n;
  n.v = sensor_v * (g.level_v / reference_v);
  n.ok = true;
  return n;
}

/// A whole recording; samples whose reference fails the guard are NaN in the result and counted.
Eigen::VectorXd normalise(const Eigen::VectorXd& sensor_v, const Eigen::VectorXd& reference_v,
                          const ReferenceGuard& g, Eigen::Index* n_rejected = nullptr);

/// The reference level of a calibration recording: the median of its finite, positive reference
/// samples (robust to a few dropouts). NaN when there is none.
double reference_level(const Eigen::VectorXd& reference_v);

}  // namespace pof::core
