// drift: a change of the output with time alone, slower than any relaxation (docs/gap.md, section
// 3, and section 4, "Slow effects on their time scales").
#include <algorithm>
#include <cmath>

#include "effect.hpp"

namespace pof::gap {
namespace drift_effect {  // named: the effects share unity batches (CMakeLists.txt)
namespace {

// A drift's fastest component is slower than the slowest relaxation the catalogue fits (creep and
// viscoelastic_relaxation: time constants up to 200 s): its half-periods are at least this long.
// Faster than that, a slow change of the output is either the fibre relaxing after the movements
// (a response to the angle's history) or a drift, and the data cannot say which by time scale;
// slower, only a drift goes on regardless of the angle. The basis is the Legendre polynomials of
// time up to the degree whose zero crossings are this far apart over the recording.
constexpr double kMinHalfPeriodS = 300.0;
constexpr int kMaxDegree = 8;  // 40 min; a longer recording keeps this resolution's shape

int degree(const Context& cx) {
  return std::clamp(static_cast<int>(std::floor(cx.duration_s / kMinHalfPeriodS)), 1, kMaxDegree);
}

// P_1 .. P_K of x = 2 t / T - 1, the first written as t/T - 1/2 (= P_1 / 2, the linear trend of
// before) so that its coefficient is the trend over the recording: Legendre polynomials are nearly
// orthogonal over evenly spaced scans, so the rate stays the linear part whatever the degree. (A
// single power series extrapolates badly into the first and last held-out blocks and is
// ill-conditioned.)
Eigen::MatrixXd legendre(const Eigen::VectorXd& t, double duration_s, int k) {
  Eigen::MatrixXd C(t.size(), k);
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    const double x = 2 * t(i) / duration_s - 1;
    double p0 = 1, p1 = x;
    C(i, 0) = x / 2;
    for (int n = 2; n <= k; ++n) {
      const double p2 = ((2 * n - 1) * x * p1 - (n - 1) * p0) / n;
      C(i, n - 1) = p2;
      p0 = p1;
      p1 = p2;
    }
  }
  return C;
}

Eigen::MatrixXd columns(double, const Context& cx, const Kinematics&) {
  return legendre(cx.s->t, cx.duration_s, degree(cx));
}

// The linear trend's rate, and the whole trend's span and RMS over the recording in degrees (on
// 400 evenly spaced times).
nlohmann::json physical(double, const Eigen::VectorXd& b, const Context& cx) {
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(400, 0.0, cx.duration_s);
  const Eigen::VectorXd trend = legendre(t, cx.duration_s, static_cast<int>(b.size())) * b;
  const double centred_ms = (trend.array() - trend.mean()).square().mean();
  const double deg = basis::as_angle_error(1.0, cx);
  return {{"drift_deg_per_min", basis::as_angle_error(b(0), cx) / (cx.duration_s / 60.0)},
          {"drift_mv_per_min", b(0) * 1e3 / (cx.duration_s / 60.0)},
          {"span_deg", std::abs(deg) * (trend.maxCoeff() - trend.minCoeff())},
          {"rms_deg", std::abs(deg) * std::sqrt(centred_ms)},
          {"degree", static_cast<double>(b.size())}};
}

}  // namespace
}  // namespace drift_effect

extern const EffectDef kDrift{
    .id = core::Effect::kDrift,
    .meaning = "a change of the output with time alone, through holds and movements alike, slower than any relaxation "
               "(source ageing, temperature)",
    .magnitude_key = "rms_deg",
    .grid = [](const Context&, const Eigen::VectorXd&) { return std::vector<double>{0.0}; },
    .columns = drift_effect::columns,
    .physical = drift_effect::physical,
    .linear_of = drift_effect::degree,
};

}  // namespace pof::gap
