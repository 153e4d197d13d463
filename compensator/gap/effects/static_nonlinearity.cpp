// static_nonlinearity: the quasi-static line bends (docs/gap.md, section 3).
#include <algorithm>
#include <cmath>
#include <limits>

#include "effect.hpp"

namespace pof::gap {
namespace static_nonlinearity_effect {  // named: the effects share unity batches (CMakeLists.txt)
namespace {

// An angle error polynomial in u = (angle - 45)/45: a bow (u^2), an S (u^3) and the +-2 %
// S-shaped linearity error of a precision potentiometer, which needs up to u^5.
Eigen::MatrixXd columns(double, const Context& cx, const Kinematics& k) {
  Eigen::MatrixXd C(cx.s->n, 4);
  const Eigen::ArrayXd u = k.angle.array().unaryExpr(&core::static_nonlinearity_u);
  C.col(0) = u.square().matrix();
  C.col(1) = u.cube().matrix();
  C.col(2) = u.square().square().matrix();
  C.col(3) = (u.square().square() * u).matrix();
  return C;
}

nlohmann::json physical(double, const Eigen::VectorXd& b, const Context& cx) {
  Eigen::Vector4d e;  // the same polynomial as an angle error [deg]
  for (int i = 0; i < 4; ++i) e(i) = basis::as_angle_error(b(i), cx);
  nlohmann::json p{{"quadratic_deg", e(0)}, {"cubic_deg", e(1)}, {"quartic_deg", e(2)}, {"quintic_deg", e(3)}};
  // The largest deviation from the chord over 0..90 deg (what the paper's linearity bounds).
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int a = 0; a <= 90; ++a) {
    const double u = core::static_nonlinearity_u(a);
    const double err = e(0) * u * u + e(1) * u * u * u + e(2) * u * u * u * u + e(3) * u * u * u * u * u;
    const double chord = (e(0) + e(2)) + (e(1) + e(3)) * u;
    lo = std::min(lo, err - chord);
    hi = std::max(hi, err - chord);
  }
  p["max_deviation_deg"] = std::abs(hi) > std::abs(lo) ? hi : lo;
  return p;
}

}  // namespace
}  // namespace static_nonlinearity_effect

extern const EffectDef kStaticNonlinearity{
    .id = core::Effect::kStaticNonlinearity,
    .meaning = "the quasi-static line bends: an angle error polynomial in the angle (bow, S, potentiometer linearity)",
    .linear = 4,
    .magnitude_key = "max_deviation_deg",
    .grid = [](const Context&, const Eigen::VectorXd&) { return std::vector<double>{0.0}; },
    .columns = static_nonlinearity_effect::columns,
    .physical = static_nonlinearity_effect::physical,
};

}  // namespace pof::gap
