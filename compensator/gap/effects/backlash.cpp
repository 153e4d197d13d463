// backlash: play in the belt between the joint and the potentiometer (docs/gap.md, section 3).
#include "effect.hpp"

namespace pof::gap {

// Kinematic: the joint the fibre sits on leads the reference by b/2 in the direction of the last
// movement (signals.cpp, apply_backlash), b on a 0.1 deg grid over 0.1..3 deg, refined to 0.01.
extern const EffectDef kBacklash{
    .id = core::Effect::kBacklash,
    .meaning = "play in the belt: the joint leads the reference by half the play in the direction of the last movement",
    .acts = Acts::kBacklash,
    .linear = 0,
    .theta_key = "width_deg",
    .magnitude_key = "width_deg",
    .refit_theta = true,
    .grid = [](const Context&, const Eigen::VectorXd&) {
      std::vector<double> g;
      for (int i = 1; i <= 30; ++i) g.push_back(0.1 * i);
      return g;
    },
    .refine = [](double best, const Context&) { return basis::linear_refine(best, 0.01, 0.0); },
    .physical = [](double b, const Eigen::VectorXd&, const Context&) { return nlohmann::json{{"width_deg", b}}; },
};

}  // namespace pof::gap
