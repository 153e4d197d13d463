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

Eigen::MatrixXd columns(double, const Context& cx, const Kinematics& k) {
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

nlohmann::json physical(double, const Eigen::VectorXd& b, const Context& cx) {
  const std::vector<double> r = bank();
  nlohmann::json p;
  double half_height = 0;
  for (std::size_t j = 0; j < r.size(); ++j) {
    const double w = basis::as_angle_error(b(static_cast<Eigen::Index>(j)), cx);
    p["weight_r" + std::to_string(static_cast<int>(r[j])) + "deg"] = w;
    half_height += w * r[j];
  }
  // Half the height of the saturated loop, as an angle: the error left at a hold after a long
  // movement, with the sign of the last movement's direction.
  p["half_height_deg"] = half_height;
  return p;
}

}  // namespace
}  // namespace memory_hysteresis_effect

extern const EffectDef kMemoryHysteresis{
    .id = core::Effect::kMemoryHysteresis,
    .meaning = "rate-independent hysteresis with memory: persists through holds, minor loops (stop operators, 1-32 deg)",
    .linear = 6,
    .magnitude_key = "half_height_deg",
    .grid = [](const Context&, const Eigen::VectorXd&) { return std::vector<double>{0.0}; },
    .columns = memory_hysteresis_effect::columns,
    .physical = memory_hysteresis_effect::physical,
    .basis_key = "thresholds_deg",
    .basis_values = [](double) { return memory_hysteresis_effect::bank(); },
};

}  // namespace pof::gap
