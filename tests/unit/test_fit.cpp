// Fits of table 2: lines with standard errors, the exponential f1, eq. (1).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "pof/core/fit.hpp"
#include "pof/core/normalise.hpp"
#include "pof/core/paper_protocol.hpp"
#include "pof/core/potentiometer.hpp"

using namespace pof::core;

TEST(Fit, LineRecoversSlopeAndStandardErrorsMatchTheScatter) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(0, 0.5);
  const int trials = 400, n = 30;
  std::vector<double> slopes;
  double se_mean = 0;
  for (int t = 0; t < trials; ++t) {
    Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(n, 0, 90), y(n);
    for (int i = 0; i < n; ++i) y(i) = -0.0219 * x(i) + 4.35 + noise(rng);
    const LinearFit f = fit_line(x, y);
    slopes.push_back(f.slope);
    se_mean += f.slope_se / trials;
    EXPECT_EQ(f.residuals.size(), n);
  }
  double m = 0, v = 0;
  for (double s : slopes) m += s / trials;
  for (double s : slopes) v += (s - m) * (s - m) / (trials - 1);
  EXPECT_NEAR(m, -0.0219, 3 * std::sqrt(v / trials));
  EXPECT_NEAR(se_mean, std::sqrt(v), 0.1 * std::sqrt(v)) << "the reported SE is the spread of the slope";
}

TEST(Fit, LineDegenerateInputsGiveNoFit) {
  Eigen::VectorXd x(3), y(3);
  x << 1, 1, 1;
  y << 1, 2, 3;
  EXPECT_EQ(fit_line(x, y).n, 0);
  EXPECT_EQ(fit_line(x.head(1), y.head(1)).n, 0);
}

TEST(Fit, ExponentialRecoversF1OfThePaper) {
  const Eigen::VectorXd w = Eigen::Map<const Eigen::VectorXd>(pof::core::kTable1Velocities.data(), 9);
  Eigen::VectorXd h(9);
  for (int i = 0; i < 9; ++i) h(i) = 2.641 * std::exp(-3.494 * w(i));
  const ExpFit f = fit_exponential(w, h);
  EXPECT_TRUE(f.converged);
  EXPECT_NEAR(f.c1, 2.641, 1e-9);
  EXPECT_NEAR(f.c2, -3.494, 1e-9);
  EXPECT_LT(f.rmse, 1e-9);
  // With noise the truth lies within ~3 standard errors.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0, 0.03);
  for (int i = 0; i < 9; ++i) h(i) += noise(rng);
  const ExpFit g = fit_exponential(w, h);
  EXPECT_GT(g.c2_se, 0);
  EXPECT_LT(std::abs(g.c2 + 3.494), 3 * g.c2_se);
  EXPECT_LT(std::abs(g.c1 - 2.641), 3 * g.c1_se);
  Eigen::VectorXd bad = h;
  bad(2) = -1;
  EXPECT_THROW(fit_exponential(w, bad), std::invalid_argument);
}

TEST(Fit, HysteresisEq1OfTwoParallelLines) {
  LineAccumulator flex, ext;
  for (double x = 0; x <= 90; x += 0.5) {
    flex.add(x, x + 1);
    ext.add(x, x - 1);
  }
  const Hysteresis h = hysteresis_eq1(flex, ext);
  ASSERT_TRUE(h.valid);
  EXPECT_NEAR(h.x_mid, 45, 1e-9);
  EXPECT_NEAR(h.span, 92, 1e-9);
  EXPECT_NEAR(h.pct, -2.0 / 92 * 100, 1e-9);
  EXPECT_FALSE(hysteresis_eq1(flex, LineAccumulator{}).valid);
}

TEST(Normalise, GuardNeverDividesByAVanishingReference) {
  ReferenceGuard g;
  g.level_v = 4.0;
  EXPECT_NEAR(normalise(3.0, 4.0, g).v, 3.0, 1e-12);
  EXPECT_NEAR(normalise(3.3, 4.4, g).v, 3.0, 1e-12) << "laser 10 % brighter: cancelled";
  for (double r : {0.0, 1e-9, -1.0, 1.9, 8.1}) {
    const auto n = normalise(3.0, r, g);
    EXPECT_FALSE(n.ok) << r;
    EXPECT_TRUE(n.finite_input);
    EXPECT_TRUE(std::isnan(n.v));
  }
  EXPECT_FALSE(normalise(std::nan(""), 4.0, g).finite_input);
  Eigen::VectorXd s(3), r(3);
  s << 3, 3, 3;
  r << 4, 0, 4;
  Eigen::Index rejected = 0;
  const Eigen::VectorXd v = normalise(s, r, g, &rejected);
  EXPECT_EQ(rejected, 1);
  EXPECT_TRUE(std::isnan(v(1)));
  EXPECT_NEAR(reference_level(r), 4.0, 1e-12);
}

TEST(Potentiometer, LinearWithInterpolatedOffsetTable) {
  PotentiometerCalibration p;
  p.deg_per_volt = 18;
  p.zero_v = 0.5;
  EXPECT_NEAR(p.angle(0.5), 0, 1e-12);
  EXPECT_NEAR(p.angle(3.0), 45, 1e-12);
  p.offsets = {{0, 0.0}, {45, 1.0}, {90, -1.0}};
  EXPECT_NEAR(p.angle(3.0), 46, 1e-12);
  EXPECT_NEAR(p.angle(0.5 + 22.5 / 18), 23, 1e-12);
  EXPECT_NEAR(p.angle(0.5 + 67.5 / 18), 67.5, 1e-12);
  EXPECT_NEAR(p.angle(0.5 + 100.0 / 18), 99, 1e-12) << "clamped beyond the table";
  Eigen::VectorXd v(2);
  v << 0.5, 3.0;
  EXPECT_NEAR(p.angles(v)(1), 46, 1e-12);
}
