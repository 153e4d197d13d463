// creep: one viscoelastic relaxation time (docs/gap.md, section 3).
#include "effect.hpp"

namespace pof::gap {
namespace creep_effect {  // named: the effects share unity batches (CMakeLists.txt)
namespace {

// Standard-linear-solid memory: the fibre sees the angle plus g (x - angle), x the angle low-passed
// with tau, so after a step the output relaxes with tau (PMMA creep: Leal-Junior, Frizera, Pontes,
// Opt. Laser Technol. 93 (2017) 92-98).
Eigen::MatrixXd columns(double tau, const Context& cx, const Kinematics& k) {
  Eigen::MatrixXd C(cx.s->n, 1);
  C.col(0) = basis::relaxation(k.angle, cx.s->dt, tau);
  return C;
}

nlohmann::json physical(double tau, const Eigen::VectorXd& b, const Context& cx) {
  return {{"tau_s", tau}, {"gain", basis::as_angle_error(b(0), cx)}, {"gain_v_per_deg", b(0)}};
}

}  // namespace
}  // namespace creep_effect

extern const EffectDef kCreep{
    .id = core::Effect::kCreep,
    .meaning = "one viscoelastic relaxation time: after a step the reading relaxes with tau (standard linear solid)",
    .theta_key = "tau_s",
    .magnitude_key = "gain",
    .refit_theta = true,
    // 1 .. 200 s. A memory shorter than ~1 s is, on the reference angle, indistinguishable from a
    // delay plus an acceleration term (LP(x) - x = -tau x' + tau^2 x'' - ...); the fibre's
    // relaxation shows over seconds in the holds.
    .grid = [](const Context&, const Eigen::VectorXd&) { return basis::log_grid(1.0, 200.0, 21); },
    .refine = [](double best, const Context&) { return basis::log_refine(best); },
    .columns = creep_effect::columns,
    .physical = creep_effect::physical,
};

}  // namespace pof::gap
