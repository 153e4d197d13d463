// viscoelastic_relaxation: relaxation over two time constants (docs/gap.md, section 3).
#include <cmath>
#include <string>
#include <utility>

#include "effect.hpp"

namespace pof::gap {
namespace viscoelastic_relaxation_effect {  // named: the effects share unity batches (CMakeLists.txt)
namespace {

// Two Prony terms (a generalised Maxwell model) at time constants at least ~4x apart: a polymer
// fibre relaxes over decades of time, which one time constant (creep) cannot follow. theta indexes
// the pair in a fixed list: both from creep's range, 1..200 s in 17 log steps (x1.39), the slow one
// at least four steps (x3.7) above the fast one; the gains are the linear coefficients. 1 s is the
// shortest for the reason creep's grid starts there (shorter memories are a delay plus acceleration).
const std::vector<double>& taus() {
  static const std::vector<double> t = basis::log_grid(1.0, 200.0, 17);
  return t;
}

// The pairs as indices into taus().
const std::vector<std::pair<std::size_t, std::size_t>>& pair_indices() {
  static const std::vector<std::pair<std::size_t, std::size_t>> p = [] {
    std::vector<std::pair<std::size_t, std::size_t>> out;
    for (std::size_t i = 0; i < taus().size(); ++i)
      for (std::size_t j = i + 4; j < taus().size(); ++j) out.emplace_back(i, j);
    return out;
  }();
  return p;
}

std::pair<std::size_t, std::size_t> indices_of(double theta) {
  const auto i = static_cast<std::size_t>(std::lround(theta));
  return pair_indices().at(std::min(i, pair_indices().size() - 1));
}

std::pair<double, double> pair_of(double theta) {
  const auto [i, j] = indices_of(theta);
  return {taus()[i], taus()[j]};
}

std::vector<double> grid(const Context&, const Eigen::VectorXd&) {
  std::vector<double> g;
  for (std::size_t i = 0; i < pair_indices().size(); ++i) g.push_back(static_cast<double>(i));
  return g;
}

Eigen::MatrixXd columns(double theta, const Context& cx, const Kinematics& k) {
  const auto [fast, slow] = pair_of(theta);
  Eigen::MatrixXd C(cx.s->n, 2);
  C.col(0) = basis::relaxation(k.angle, cx.s->dt, fast);
  C.col(1) = basis::relaxation(k.angle, cx.s->dt, slow);
  return C;
}

// Every time constant's column: each pair is two of them.
Eigen::MatrixXd column_set(const Context& cx, const Kinematics& k) {
  Eigen::MatrixXd C(cx.s->n, static_cast<Eigen::Index>(taus().size()));
  for (std::size_t i = 0; i < taus().size(); ++i)
    C.col(static_cast<Eigen::Index>(i)) = basis::relaxation(k.angle, cx.s->dt, taus()[i]);
  return C;
}

std::vector<Eigen::Index> columns_in_set(double theta) {
  const auto [i, j] = indices_of(theta);
  return {static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)};
}

nlohmann::json physical(double theta, const Eigen::VectorXd& b, const Context& cx) {
  const auto [fast, slow] = pair_of(theta);
  const double gf = basis::as_angle_error(b(0), cx), gs = basis::as_angle_error(b(1), cx);
  // Gains as creep's: the fraction of a sudden bend that relaxes with that time constant.
  return {{"tau_fast_s", fast}, {"tau_slow_s", slow}, {"gain_fast", gf}, {"gain_slow", gs}, {"total_gain", gf + gs}};
}

// A relaxation modulus is a sum of decaying exponentials with positive weights (springs and
// dashpots): both gains have one sign. Gains of both signs that the jackknife tells apart from zero
// make a band-pass memory, not a fibre's relaxation; such a fit is taking up something else (a
// delay, an acceleration term).
std::string inadmissible(const nlohmann::json& p) {
  auto sig = [&](const char* k) {
    const double g = p.value(k, 0.0), se = p.value(std::string(k) + "_se", 0.0);
    return std::abs(g) > 2 * se ? (g > 0 ? 1 : -1) : 0;
  };
  return sig("gain_fast") * sig("gain_slow") < 0 ? "gains of both signs beyond 2 SE: not a relaxation spectrum" : "";
}

void write_basis(double theta, const Context&, core::GapTerm& term) {
  const auto [fast, slow] = pair_of(theta);
  term.time_constants_s = {fast, slow};
}

}  // namespace
}  // namespace viscoelastic_relaxation_effect

extern const EffectDef kViscoelasticRelaxation{
    .id = core::Effect::kViscoelasticRelaxation,
    .meaning = "relaxation over two time constants (Prony series, 1-200 s): the fibre's viscoelastic spectrum",
    .linear = 2,
    .theta_key = "pair_index",
    .magnitude_key = "total_gain",
    .grid = viscoelastic_relaxation_effect::grid,
    .columns = viscoelastic_relaxation_effect::columns,
    .column_set = viscoelastic_relaxation_effect::column_set,
    .columns_in_set = viscoelastic_relaxation_effect::columns_in_set,
    .physical = viscoelastic_relaxation_effect::physical,
    .inadmissible = viscoelastic_relaxation_effect::inadmissible,
    .generalises = core::Effect::kCreep,
    .theta_in_file = false,
    .write_basis = viscoelastic_relaxation_effect::write_basis,
};

}  // namespace pof::gap
