#pragma once
// The exoskeleton's reference angle: a 10 kOhm potentiometer (+-2 % linearity) on the harmonic
// drive output (Leal-Junior et al. 2017, section 2.1). angle_deg = deg_per_volt * (pot_v - zero_v)
// plus an optional offset table (angle -> correction [deg], linear interpolation, clamped at the
// ends) that takes out the potentiometer's non-linearity. TOML section [potentiometer] (brief).
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace pof::core {

struct PotentiometerCalibration {
  double deg_per_volt = 18.0;
  double zero_v = 0.0;
  /// (angle [deg], correction [deg]) sorted by angle; empty = none.
  std::vector<std::pair<double, double>> offsets;

  [[nodiscard]] double angle(double pot_v) const;
  [[nodiscard]] Eigen::VectorXd angles(const Eigen::VectorXd& pot_v) const;
};

}  // namespace pof::core
