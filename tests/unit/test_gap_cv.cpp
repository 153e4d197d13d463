// The search's linear algebra on its own (gap/src/cv.hpp, private to pof_gap): the one-signed
// least squares that holds a memory term's stop-operator weights to one sign.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <Eigen/Dense>

#include "cv.hpp"

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// The residual's sum of squares less y'y, from the normal equations.
double objective(const MatrixXd& G, const VectorXd& g, const VectorXd& b) { return b.dot(G * b) - 2 * b.dot(g); }

// The constrained optimum by enumeration: every subset of the signed coefficients held at zero,
// the rest by least squares; the best whose signed coefficients all have the sign s.
VectorXd brute_force(const MatrixXd& G, const VectorXd& g, Index first, Index m, double s) {
  const Index k = G.rows();
  VectorXd best;
  double best_f = std::numeric_limits<double>::infinity();
  for (unsigned mask = 0; mask < (1u << m); ++mask) {
    std::vector<Index> p;
    for (Index i = 0; i < k; ++i)
      if (i < first || i >= first + m || (mask >> (i - first) & 1u) != 0) p.push_back(i);
    VectorXd b = VectorXd::Zero(k);
    const MatrixXd Gp = G(p, p);
    const VectorXd gp = g(p);
    const VectorXd bp = Gp.ldlt().solve(gp);
    b(p) = bp;
    bool ok = true;
    for (Index i = first; i < first + m; ++i) ok = ok && s * b(i) >= -1e-12;
    if (ok && objective(G, g, b) < best_f) { best_f = objective(G, g, b); best = b; }
  }
  return best;
}

// A bank of five stop operators on a random walk, beside two free columns, fitted to a loop of
// one sign plus a made-up sharp part that least squares answers with weights of both signs.
TEST(GapCv, OneSignedWeightsAreTheConstrainedOptimum) {
  std::mt19937_64 rng(17);
  std::normal_distribution<double> n01(0, 1);
  const std::vector<double> r = {1, 2, 4, 8, 16};
  const Index n = 4000, m = 5, first = 1, k = 7;
  int mixed = 0;
  for (int trial = 0; trial < 40; ++trial) {
    MatrixXd X(n, k);
    double a = 0, prev = 0;
    std::vector<double> s(r.size(), 0.0);
    for (Index i = 0; i < n; ++i) {
      a += 0.8 * n01(rng);
      for (std::size_t j = 0; j < r.size(); ++j) s[j] = std::clamp(s[j] + a - prev, -r[j], r[j]);
      prev = a;
      X(i, 0) = 1;
      for (Index j = 0; j < m; ++j) X(i, first + j) = s[static_cast<std::size_t>(j)];
      X(i, k - 1) = std::sin(0.01 * static_cast<double>(i));
    }
    VectorXd truth(k);
    const double sign = trial % 2 == 0 ? 1.0 : -1.0;
    truth << 0.3, sign * 0.5, -sign * 0.9, sign * 0.2, 0.0, sign * 0.05, 0.4;  // one weight against the loop
    const VectorXd y = X * truth + 0.2 * VectorXd::NullaryExpr(n, [&] { return n01(rng); });
    const MatrixXd G = X.transpose() * X;
    const VectorXd g = X.transpose() * y;
    const VectorXd free_fit = pof::gap::cv::solve(G, g);
    const VectorXd b = pof::gap::cv::solve_one_signed(G, g, {{first, r}});
    double height = 0;
    for (Index j = 0; j < m; ++j) height += r[static_cast<std::size_t>(j)] * free_fit(first + j);
    const double s0 = height >= 0 ? 1.0 : -1.0;
    bool both = false;
    for (Index j = 0; j < m; ++j) both = both || s0 * free_fit(first + j) < 0;
    if (!both) {
      EXPECT_LT((b - free_fit).norm(), 1e-9 * free_fit.norm()) << "a one-signed fit must be left as it is";
      continue;
    }
    ++mixed;
    for (Index j = 0; j < m; ++j) EXPECT_GE(s0 * b(first + j), 0.0) << "trial " << trial << " weight " << j;
    const VectorXd want = brute_force(G, g, first, m, s0);
    EXPECT_NEAR(objective(G, g, b), objective(G, g, want), 1e-9 * std::abs(objective(G, g, want))) << "trial " << trial;
    EXPECT_LT((b - want).norm(), 1e-6 * want.norm()) << "trial " << trial;
  }
  EXPECT_GE(mixed, 20) << "too few trials exercise the constraint";
}

// Coefficients outside every group are never constrained, and two groups keep their own signs.
TEST(GapCv, TwoGroupsKeepTheirOwnSigns) {
  // Orthonormal columns: the least squares solution is g itself, the constrained one g with the
  // coefficients against their group's sign set to zero.
  const MatrixXd G = MatrixXd::Identity(6, 6);
  VectorXd g(6);
  g << -3, 2, -0.5, -1, 4, 0.3;  // group A: 0..2; free: 3; group B: 4..5
  const VectorXd b = pof::gap::cv::solve_one_signed(G, g, {{0, {1, 2, 4}}, {4, {1, 1}}});
  // A's height -3 + 4 - 2 = -1 < 0, so its +2 goes to zero; B's 4.3 > 0 keeps both; -1 is free.
  VectorXd want(6);
  want << -3, 0, -0.5, -1, 4, 0.3;
  EXPECT_LT((b - want).norm(), 1e-9);
}

}  // namespace
