// drift: an offset that grows linearly over the recording (docs/gap.md, section 3).
#include "effect.hpp"

namespace pof::gap {
namespace {

// Linear in time, t/T - 1/2: a quadratic term extrapolates badly into the first and last held-out
// blocks and starts to mimic any slow wander (e.g. of the light source).
Eigen::MatrixXd columns(double, const Context& cx, const Kinematics&) {
  Eigen::MatrixXd C(cx.s->n, 1);
  C.col(0) = (cx.s->t.array() / cx.duration_s - 0.5).matrix();
  return C;
}

nlohmann::json physical(double, const Eigen::VectorXd& b, const Context& cx) {
  return {{"drift_deg_per_min", basis::as_angle_error(b(0), cx) / (cx.duration_s / 60.0)},
          {"drift_mv_per_min", b(0) * 1e3 / (cx.duration_s / 60.0)}};
}

}  // namespace

extern const EffectDef kDrift{
    .id = core::Effect::kDrift,
    .meaning = "an offset that grows with time over the recording (source ageing, temperature)",
    .magnitude_key = "drift_deg_per_min",
    .grid = [](const Context&, const Eigen::VectorXd&) { return std::vector<double>{0.0}; },
    .columns = columns,
    .physical = physical,
};

}  // namespace pof::gap
