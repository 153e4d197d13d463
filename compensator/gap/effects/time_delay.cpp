// time_delay: the sensor channel sees the angle late (docs/gap.md, section 3).
#include "effect.hpp"

namespace pof::gap {

// Kinematic: the whole baseline is rebuilt with the angle at t - d (linear interpolation), for
// d on a 10 ms grid over +-250 ms, refined to 1 ms around the best.
extern const EffectDef kTimeDelay{
    .id = core::Effect::kTimeDelay,
    .meaning = "the sensor sees the angle late or early (filters, DAQ buffering, channel skew)",
    .acts = Acts::kDelay,
    .linear = 0,
    .theta_key = "delay_ms",
    .theta_scale = 1e3,
    .magnitude_key = "delay_ms",
    .refit_theta = true,
    .grid = [](const Context&, const Eigen::VectorXd&) {
      std::vector<double> g;
      for (int i = -25; i <= 25; ++i) g.push_back(i * 0.01);
      return g;
    },
    .refine = [](double best, const Context&) { return basis::linear_refine(best, 0.001, -1.0); },
    .physical = [](double d, const Eigen::VectorXd&, const Context&) { return nlohmann::json{{"delay_ms", d * 1e3}}; },
};

}  // namespace pof::gap
