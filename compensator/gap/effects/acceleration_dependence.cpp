// acceleration_dependence: a term in the angular acceleration (docs/gap.md, section 3).
#include <algorithm>
#include <cmath>
#include <numbers>

#include "effect.hpp"
#include "pof/core/units.hpp"

namespace pof::gap {
namespace acceleration_dependence_effect {  // named: the effects share unity batches (CMakeLists.txt)
namespace {

// The acceleration of the angle, differentiated twice over +-h: a short window follows the drive's
// acceleration steps, a long one keeps potentiometer noise out; h is chosen on the training blocks.
Eigen::MatrixXd columns(double h_s, const Context& cx, const Kinematics& k) {
  const double dt = cx.s->dt;
  const auto h = std::max<Eigen::Index>(1, static_cast<Eigen::Index>(std::lround(h_s / dt)));
  const Eigen::VectorXd w = local_slope(k.angle, dt, h) * core::kRadPerDeg;
  Eigen::MatrixXd C(cx.s->n, 1);
  C.col(0) = local_slope(w, dt, h);
  return C;
}

nlohmann::json physical(double h_s, const Eigen::VectorXd& b, const Context& cx) {
  return {{"gain_deg_per_rad_s2", basis::as_angle_error(b(0), cx)}, {"gain_v_per_rad_s2", b(0)}, {"window_s", h_s}};
}

}  // namespace
}  // namespace acceleration_dependence_effect

extern const EffectDef kAccelerationDependence{
    .id = core::Effect::kAccelerationDependence,
    .meaning = "a term in the angular acceleration (inertia of the fibre in its sleeve)",
    .theta_key = "window_s",
    .magnitude_key = "gain_deg_per_rad_s2",
    .refit_theta = true,
    .grid = [](const Context&, const Eigen::VectorXd&) { return std::vector<double>{0.015, 0.025, 0.035, 0.05, 0.075, 0.1}; },
    .columns = acceleration_dependence_effect::columns,
    .physical = acceleration_dependence_effect::physical,
};

}  // namespace pof::gap
