// source_power_coupling: imperfect cancellation of the source power (docs/gap.md, section 3).
#include <cmath>

#include "effect.hpp"

namespace pof::gap {
namespace source_power_coupling_effect {  // named: the effects share unity batches (CMakeLists.txt)
namespace {

// v ~ T(angle) (1 + gamma dP/P) + o dP/P: the two photodiodes respond differently to the source
// power (or the reference has a dark offset), dP/P as the reference fibre sees it (1 s mean).
Eigen::MatrixXd columns(double, const Context& cx, const Kinematics& k) {
  Eigen::MatrixXd C(cx.s->n, 2);
  C.col(0) = basis::quasi_static_v(cx, k).cwiseProduct(cx.s->ref_rel);
  C.col(1) = cx.s->ref_rel;
  return C;
}

std::string_view not_identifiable(const Context& cx) {
  if (std::sqrt(cx.s->ref_rel.squaredNorm() / static_cast<double>(cx.s->n)) < 1e-4)
    return "reference level constant (< 0.01 % RMS): coupling not identifiable";
  return {};
}

}  // namespace
}  // namespace source_power_coupling_effect

extern const EffectDef kSourcePowerCoupling{
    .id = core::Effect::kSourcePowerCoupling,
    .meaning = "the reference fibre does not cancel the source power exactly (photodiode responses, dark offset)",
    .linear = 2,
    .grid = [](const Context&, const Eigen::VectorXd&) { return std::vector<double>{0.0}; },
    .columns = source_power_coupling_effect::columns,
    .physical = [](double, const Eigen::VectorXd& b, const Context&) { return nlohmann::json{{"gamma", b(0)}, {"offset_v", b(1)}}; },
    .not_identifiable = source_power_coupling_effect::not_identifiable,
    .fast_part_s = 40,  // the simulator's and a lab LED's wander: minutes; its steps and flicker: faster
};

}  // namespace pof::gap
