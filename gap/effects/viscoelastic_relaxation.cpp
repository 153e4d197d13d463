// viscoelastic_relaxation: relaxation over several time constants (docs/gap.md, section 3).
#include "effect.hpp"

namespace pof::gap {
namespace {

// A Prony series on a fixed, log-spaced bank of time constants (generalised Maxwell model): a
// polymer fibre relaxes over decades of time, which one time constant (creep) cannot follow. With
// the bank fixed the term stays linear; the weights are the relaxation spectrum. The bank starts at
// 1 s for the reason creep's grid does (shorter memories are a delay plus acceleration).
std::vector<double> bank() { return {1.0, 3.0, 10.0, 30.0, 100.0}; }

Eigen::MatrixXd columns(double, const Context& cx, const Kinematics& k) {
  const std::vector<double> taus = bank();
  Eigen::MatrixXd C(cx.s->n, static_cast<Eigen::Index>(taus.size()));
  for (std::size_t j = 0; j < taus.size(); ++j)
    C.col(static_cast<Eigen::Index>(j)) = basis::relaxation(k.angle, cx.s->dt, taus[j]);
  return C;
}

nlohmann::json physical(double, const Eigen::VectorXd& b, const Context& cx) {
  const std::vector<double> taus = bank();
  nlohmann::json p;
  double total = 0, weighted = 0;
  for (std::size_t j = 0; j < taus.size(); ++j) {
    const double g = basis::as_angle_error(b(static_cast<Eigen::Index>(j)), cx);
    p["gain_tau_" + std::to_string(static_cast<int>(taus[j])) + "s"] = g;
    total += g;
    weighted += g * std::log(taus[j]);
  }
  p["total_gain"] = total;  // the step response's relaxed part, as a fraction of the step
  // The spectrum's centre (log-mean of the time constants, weighted by gain) when the gains agree in sign.
  p["mean_tau_s"] = total != 0 ? std::exp(weighted / total) : 0.0;
  return p;
}

}  // namespace

extern const EffectDef kViscoelasticRelaxation{
    .id = core::Effect::kViscoelasticRelaxation,
    .meaning = "relaxation over several time constants (a Prony series on 1-100 s): the fibre's viscoelastic spectrum",
    .linear = 5,
    .grid = [](const Context&, const Eigen::VectorXd&) { return std::vector<double>{0.0}; },
    .columns = columns,
    .physical = physical,
    .basis_key = "time_constants_s",
    .basis_values = bank,
};

}  // namespace pof::gap
