// memory_hysteresis: a rate-independent loop with memory (docs/gap.md, section 3).
#include <algorithm>

#include "effect.hpp"

namespace pof::gap {
namespace memory_hysteresis_effect {  // named: the effects share unity batches (CMakeLists.txt)
namespace {

// Prandtl-Ishlinskii stop operators on a fixed bank of thresholds (Brokate & Sprekels 1996,
// "Hysteresis and Phase Transitions", ch. 2; a Maxwell-slip model): S_k = clamp(S_k-1 + angle_k -
// angle_k-1, -r, r). Unlike the paper's hysteresis, the operators keep their state through holds
// (the loop does not close when the knee stops), a reversal part-way unsaturates only the small
// operators (minor loops inside the major one), and speed plays no part. The bank reaches a loop as
// wide as most of the knee's range (64 deg), as the dynamic fit's own operators do (0.4 of the
// angle span): a polymer's relays that switch 20 deg either side of a mid-range angle draw such a
// loop, and a bank ending at 16 left it in the holds (docs/gap.md, section 3).
std::vector<double> bank() { return {1.0, 2.0, 4.0, 8.0, 16.0, 32.0}; }

// The relay form (theta = the relays' half-width h > 0; core::relay_places): a Preisach loop
// fixed at absolute angles, which stop operators, whose loops follow the reversals, cannot draw
// (docs/gap.md, section 3, "A loop at a fixed angle"). The dynamic baseline holds stop operators
// of its own, so there the memory term is this form only; on the paper structure, the bank above.
// Six knots, as many as the bank has thresholds, spread over the centres whose relays switch
// within the recording's range: [min + h, max - h]. Widths 4-24 deg span a polymer's relay
// half-widths; each width needs the knots 2 deg apart at least.
constexpr int kKnots = 6;
std::vector<double> relay_widths() { return {4.0, 8.0, 12.0, 16.0, 24.0}; }

std::vector<double> knots(double h, const Context& cx) {
  const double lo = cx.angle_min_deg + h, hi = cx.angle_max_deg - h;
  const double most = core::kRelaySpacingDeg * static_cast<double>(core::kMaxRelays - 1);  // what a file may hold
  if (!(hi - lo >= 2.0 * (kKnots - 1)) || !(hi - lo <= most)) return {};
  std::vector<double> k;
  for (int i = 0; i < kKnots; ++i) k.push_back(lo + (hi - lo) * i / (kKnots - 1));
  return k;
}

std::vector<double> grid(const Context& cx, const Eigen::VectorXd&) {
  if (!cx.dyn) return {0.0};
  std::vector<double> g;
  for (const double h : relay_widths())
    if (!knots(h, cx).empty()) g.push_back(h);
  return g;
}

// On the dynamic baseline with no width whose knots fit the range: no relay loop to offer.
std::string_view not_identifiable(const Context& cx) {
  if (cx.dyn && grid(cx, Eigen::VectorXd()).empty())
    return "the recording's angle range is too narrow for a relay loop beside the dynamic baseline's stop operators";
  return {};
}

Eigen::MatrixXd relay_columns(double h, const Context& cx, const Kinematics& k) {
  const Eigen::Index n = cx.s->n;
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(n, kKnots);
  for (const core::RelayPlace& p : core::relay_places(knots(h, cx))) {
    const auto k0 = static_cast<Eigen::Index>(p.knot);
    const double alpha = p.centre_deg + h, beta = p.centre_deg - h;
    double r = core::relay_start(k.angle(0), p.centre_deg);
    for (Eigen::Index i = 0; i < n; ++i) {
      r = core::relay_step(r, k.angle(i), alpha, beta);
      C(i, k0) += (1 - p.frac) * r;
      C(i, k0 + 1) += p.frac * r;
    }
  }
  return C;
}

Eigen::MatrixXd columns(double theta, const Context& cx, const Kinematics& k) {
  if (theta > 0) return relay_columns(theta, cx, k);
  const std::vector<double> r = bank();
  const Eigen::Index n = cx.s->n;
  Eigen::MatrixXd C(n, static_cast<Eigen::Index>(r.size()));
  for (std::size_t j = 0; j < r.size(); ++j) {
    double s = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (i > 0) s = std::clamp(s + k.angle(i) - k.angle(i - 1), -r[j], r[j]);
      C(i, static_cast<Eigen::Index>(j)) = s;
    }
  }
  return C;
}

// Half the height of the saturated loop, as an angle: the error left at a hold after a long
// movement, with the sign of the last movement's direction. Stop operators: sum of w_j r_j;
// relays: the sum of every relay's weight, and where the loop sits (the centres' mean weighted by
// |w|: a fold's unconstrained fit may give weights of both signs).
// The keys are the same at every width: the jackknife pairs them over folds that chose others.
nlohmann::json physical(double theta, const Eigen::VectorXd& b, const Context& cx) {
  nlohmann::json p;
  double half_height = 0;
  if (theta > 0) {
    double moment = 0, mass = 0;
    for (const core::RelayPlace& r : core::relay_places(knots(theta, cx))) {
      const auto k0 = static_cast<Eigen::Index>(r.knot);
      const double w = basis::as_angle_error((1 - r.frac) * b(k0) + r.frac * b(k0 + 1), cx);
      half_height += w;
      mass += std::abs(w);
      moment += std::abs(w) * r.centre_deg;
    }
    p["relay_half_width_deg"] = theta;
    p["loop_centre_deg"] = mass > 0 ? moment / mass : 0.5 * (cx.angle_min_deg + cx.angle_max_deg);
  } else {
    const std::vector<double> r = bank();
    for (std::size_t j = 0; j < r.size(); ++j) {
      const double w = basis::as_angle_error(b(static_cast<Eigen::Index>(j)), cx);
      p["weight_r" + std::to_string(static_cast<int>(r[j])) + "deg"] = w;
      half_height += w * r[j];
    }
  }
  p["half_height_deg"] = half_height;
  return p;
}

void write_basis(double theta, const Context& cx, core::GapTerm& term) {
  if (theta > 0) term.relay_centres_deg = knots(theta, cx);
  else term.thresholds_deg = bank();
}

}  // namespace
}  // namespace memory_hysteresis_effect

// The relay width is chosen on the grid but not counted as a parameter (no theta_key): a fixed
// bank on the paper structure has none, and the memory term's evidence is its held-out reduction.
extern const EffectDef kMemoryHysteresis{
    .id = core::Effect::kMemoryHysteresis,
    .meaning = "rate-independent hysteresis with memory: persists through holds, minor loops (stop operators "
               "1-32 deg; Preisach relays on the dynamic baseline)",
    .linear = 6,
    .magnitude_key = "half_height_deg",
    .grid = memory_hysteresis_effect::grid,
    .columns = memory_hysteresis_effect::columns,
    .physical = memory_hysteresis_effect::physical,
    .not_identifiable = memory_hysteresis_effect::not_identifiable,
    .write_basis = memory_hysteresis_effect::write_basis,
};

}  // namespace pof::gap
