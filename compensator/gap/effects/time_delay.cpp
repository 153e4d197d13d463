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
    // On the dynamic baseline the delay adds to the fibre's bend lag the structure carries (a lag and
    // a delay look alike at these speeds: docs/gap.md, section 1, "What the baseline names"): the
    // lateness a user would measure is both, with_bend_lag_ms.
    .physical = [](double d, const Eigen::VectorXd&, const Context& cx) {
      nlohmann::json p{{"delay_ms", d * 1e3}};
      if (cx.dyn && cx.dyn->bend_lag_s > 0) p["with_bend_lag_ms"] = 1e3 * (d + cx.dyn->bend_lag_s);
      return p;
    },
};

}  // namespace pof::gap
