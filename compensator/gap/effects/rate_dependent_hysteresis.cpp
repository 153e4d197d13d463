// rate_dependent_hysteresis: a loop opening that grows with speed (docs/gap.md, section 3).
#include <cmath>
#include <numbers>

#include "effect.hpp"

namespace pof::gap {
namespace rate_dependent_hysteresis_effect {  // named: the effects share unity batches (CMakeLists.txt)
namespace {

// A direction-signed opening that saturates with the speed, +-A (1 - exp(-|w|/w0)) sin(pi angle/90)
// (largest mid-range, as viscoelastic hysteresis is; paper sect. 2.2), w0 = theta, with no memory:
// it vanishes the moment the knee stops, unlike creep and memory hysteresis.
Eigen::MatrixXd columns(double w0, const Context& cx, const Kinematics& k) {
  Eigen::MatrixXd C(cx.s->n, 1);
  for (Eigen::Index i = 0; i < cx.s->n; ++i)
    C(i, 0) = k.s_move(i) * (1.0 - std::exp(-std::abs(k.w(i)) / w0)) * std::sin(std::numbers::pi * k.angle(i) / 90.0);
  return C;
}

nlohmann::json physical(double w0, const Eigen::VectorXd& b, const Context& cx) {
  return {{"amplitude_mv", b(0) * 1e3}, {"amplitude_deg", basis::as_angle_error(b(0), cx)}, {"velocity_scale_rad_s", w0}};
}

}  // namespace
}  // namespace rate_dependent_hysteresis_effect

extern const EffectDef kRateDependentHysteresis{
    .id = core::Effect::kRateDependentHysteresis,
    .meaning = "a loop opening that grows with speed and vanishes in holds (no memory)",
    .theta_key = "velocity_scale_rad_s",
    .magnitude_key = "amplitude_deg",
    .refit_theta = true,
    .grid = [](const Context&, const Eigen::VectorXd&) { return basis::log_grid(0.02, 1.0, 13); },
    .refine = [](double best, const Context&) { return basis::log_refine(best); },
    .columns = rate_dependent_hysteresis_effect::columns,
    .physical = rate_dependent_hysteresis_effect::physical,
    .file_coefficients = 2,
};

}  // namespace pof::gap
