// Fits of table 2: lines with standard errors, the exponential f1, eq. (1).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include <Eigen/Dense>

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

namespace {

// The residual's sum of squares less y'y, from the normal equations.
double objective(const Eigen::MatrixXd& G, const Eigen::VectorXd& g, const Eigen::VectorXd& b) {
  return b.dot(G * b) - 2 * b.dot(g);
}

// The one-signed optimum by enumeration: for each sign, every subset of the group held at zero
// and the rest by least squares; the best whose group has that sign throughout.
Eigen::VectorXd one_signed_by_enumeration(const Eigen::MatrixXd& G, const Eigen::VectorXd& g, Eigen::Index first,
                                          Eigen::Index size) {
  const Eigen::Index k = G.rows();
  Eigen::VectorXd best;
  double best_f = std::numeric_limits<double>::infinity();
  for (const double sign : {1.0, -1.0})
    for (unsigned mask = 0; mask < (1u << size); ++mask) {
      std::vector<Eigen::Index> p;
      for (Eigen::Index i = 0; i < k; ++i)
        if (i < first || i >= first + size || (mask >> (i - first) & 1u) != 0) p.push_back(i);
      const Eigen::MatrixXd Gp = G(p, p);
      const Eigen::VectorXd gp = g(p);
      const Eigen::VectorXd bp = Gp.ldlt().solve(gp);
      Eigen::VectorXd b = Eigen::VectorXd::Zero(k);
      b(p) = bp;
      bool ok = true;
      for (Eigen::Index i = first; i < first + size; ++i) ok = ok && sign * b(i) >= -1e-12;
      if (ok && objective(G, g, b) < best_f) {
        best_f = objective(G, g, b);
        best = b;
      }
    }
  return best;
}

}  // namespace

// A bank of five stop operators (thresholds 1-16 deg) on a random walk, between an offset and a
// slow free column. Half the trials draw weights of one sign, which least squares returns as they
// are; the other half one weight against the rest, which the one-signed fit must hold at zero
// or turn, reaching the enumerated optimum.
TEST(Fit, OneSignedLeastSquaresIsTheConstrainedOptimum) {
  std::mt19937_64 rng(17);
  std::normal_distribution<double> n01(0, 1);
  const std::vector<double> r = {1, 2, 4, 8, 16};
  const Eigen::Index n = 4000, first = 1, size = 5, k = 7;
  int constrained = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Eigen::MatrixXd X(n, k);
    double a = 0, prev = 0;
    std::vector<double> s(r.size(), 0.0);
    for (Eigen::Index i = 0; i < n; ++i) {
      a += 0.8 * n01(rng);
      for (std::size_t j = 0; j < r.size(); ++j) s[j] = std::clamp(s[j] + a - prev, -r[j], r[j]);
      prev = a;
      X(i, 0) = 1;
      for (Eigen::Index j = 0; j < size; ++j) X(i, first + j) = s[static_cast<std::size_t>(j)];
      X(i, k - 1) = std::sin(0.01 * static_cast<double>(i));
    }
    const double sign = trial % 4 < 2 ? 1.0 : -1.0;
    const bool against = trial % 2 == 1;
    Eigen::VectorXd truth(k);
    truth << 0.3, sign * 0.5, (against ? -0.9 : 0.9) * sign, sign * 0.2, against ? 0.0 : sign * 0.1, sign * 0.05, 0.4;
    const Eigen::VectorXd y = X * truth + 0.2 * Eigen::VectorXd::NullaryExpr(n, [&] { return n01(rng); });
    const Eigen::MatrixXd G = X.transpose() * X;
    const Eigen::VectorXd g = X.transpose() * y;
    const Eigen::VectorXd b = one_signed_least_squares(G, g, first, size);
    const Eigen::VectorXd want = one_signed_by_enumeration(G, g, first, size);
    const Eigen::VectorXd free_fit = G.ldlt().solve(g);
    const auto part = free_fit.segment(first, size).array();
    if ((part >= 0).all() || (part <= 0).all()) {
      EXPECT_LT((b - free_fit).norm(), 1e-6 * free_fit.norm()) << "trial " << trial << ": a one-signed fit is the optimum";
    } else {
      ++constrained;
    }
    const auto got = b.segment(first, size).array();
    EXPECT_TRUE((got >= 0).all() || (got <= 0).all()) << "trial " << trial << ": " << b.transpose();
    EXPECT_NEAR(objective(G, g, b), objective(G, g, want), 1e-9 * std::abs(objective(G, g, want))) << "trial " << trial;
    EXPECT_LT((b - want).norm(), 1e-6 * want.norm()) << "trial " << trial;
  }
  EXPECT_GE(constrained, 15) << "too few trials exercise the constraint";
  EXPECT_LE(constrained, 25) << "too few trials are one-signed already";
}

// The sign is the one that fits better, not the one of the loop's height: a group whose two
// smallest operators outweigh the large one in the fit but not in their thresholds' sum.
TEST(Fit, OneSignedLeastSquaresTakesTheBetterSign) {
  // Orthonormal columns: the unconstrained solution is g; for a sign, the group's coefficients of
  // the other sign go to zero, and the better sign keeps the larger sum of squares.
  const Eigen::MatrixXd G = Eigen::MatrixXd::Identity(4, 4);
  Eigen::VectorXd g(4);
  g << 0.7, -2, -2, 1;  // free; a group of three (with thresholds 1, 2, 16 deg its height is 10 > 0)
  const Eigen::VectorXd b = one_signed_least_squares(G, g, 1, 3);
  Eigen::VectorXd want(4);
  want << 0.7, -2, -2, 0;
  EXPECT_LT((b - want).norm(), 1e-9) << b.transpose();
  // No group: plain least squares.
  EXPECT_LT((one_signed_least_squares(G, g, 0, 0) - g).norm(), 1e-9);
}

// The damped step: the first scale the trial takes, halving from 1; none taken is empty.
TEST(Fit, HalvingSearchTakesTheFirstScaleAccepted) {
  std::vector<double> tried;
  const auto taken = pof::core::halving_search([&](double scale) -> std::optional<double> {
    tried.push_back(scale);
    if (scale < 0.2) return 10 * scale;
    return std::nullopt;
  });
  ASSERT_TRUE(taken.has_value());
  EXPECT_EQ(*taken, 1.25);
  EXPECT_EQ(tried, (std::vector<double>{1, 0.5, 0.25, 0.125}));
  tried.clear();
  EXPECT_FALSE(pof::core::halving_search([&](double scale) -> std::optional<double> {
    tried.push_back(scale);
    return std::nullopt;
  }, 3));
  EXPECT_EQ(tried, (std::vector<double>{1, 0.5, 0.25, 0.125}));
}
