#include "pof/core/fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

namespace pof::core {

namespace {
double r_squared(const Eigen::VectorXd& y, const Eigen::VectorXd& residuals) {
  const double ss_tot = (y.array() - y.mean()).square().sum();
  return ss_tot > 0 ? 1.0 - residuals.squaredNorm() / ss_tot : 0.0;
}
}  // namespace

LinearFit fit_line(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& y) {
  LinearFit f;
  const Eigen::Index n = std::min(x.size(), y.size());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  f.slope = f.intercept = f.slope_se = f.intercept_se = nan;
  if (n < 2) return f;
  const double mx = x.head(n).mean(), my = y.head(n).mean();
  const Eigen::ArrayXd dx = x.head(n).array() - mx;
  const double sxx = dx.square().sum();
  if (!(sxx > 0)) return f;
  f.n = n;
  f.slope = (dx * (y.head(n).array() - my)).sum() / sxx;
  f.intercept = my - f.slope * mx;
  f.residuals = y.head(n).array() - (f.slope * x.head(n).array() + f.intercept);
  const double ssr = f.residuals.squaredNorm();
  const double dn = static_cast<double>(n);
  f.rmse = std::sqrt(ssr / dn);
  f.r2 = r_squared(y.head(n), f.residuals);
  if (n > 2) {
    const double s2 = ssr / (dn - 2);
    f.slope_se = std::sqrt(s2 / sxx);
    f.intercept_se = std::sqrt(s2 * (1.0 / dn + mx * mx / sxx));
  } else {
    f.slope_se = f.intercept_se = 0;
  }
  return f;
}

double ExpFit::operator()(double x) const { return c1 * std::exp(c2 * x); }

ExpFit fit_exponential(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& y) {
  const Eigen::Index n = std::min(x.size(), y.size());
  if (n < 2) throw std::invalid_argument("exponential fit needs at least 2 points");
  if ((y.head(n).array() <= 0).any()) throw std::invalid_argument("exponential fit needs y > 0");
  // Start: ln y = ln c1 + c2 x.
  const LinearFit lf = fit_line(x.head(n), y.head(n).array().log().matrix());
  if (lf.n == 0) throw std::invalid_argument("exponential fit needs at least 2 distinct x");
  ExpFit f;
  f.c1 = std::exp(lf.intercept);
  f.c2 = lf.slope;
  Eigen::MatrixXd J(n, 2);
  Eigen::VectorXd r(n);
  for (int it = 0; it < 50; ++it) {
    const Eigen::ArrayXd e = (f.c2 * x.head(n).array()).exp();
    J.col(0) = e.matrix();
    J.col(1) = (f.c1 * x.head(n).array() * e).matrix();
    r = y.head(n).array() - f.c1 * e;
    const Eigen::Vector2d step = J.colPivHouseholderQr().solve(r);
    f.c1 += step(0);
    f.c2 += step(1);
    f.iterations = it + 1;
    if (std::abs(step(0)) <= 1e-12 * (1 + std::abs(f.c1)) && std::abs(step(1)) <= 1e-12 * (1 + std::abs(f.c2))) {
      f.converged = true;
      break;
    }
  }
  const Eigen::ArrayXd e = (f.c2 * x.head(n).array()).exp();
  J.col(0) = e.matrix();
  J.col(1) = (f.c1 * x.head(n).array() * e).matrix();
  f.residuals = y.head(n).array() - f.c1 * e;
  const double ssr = f.residuals.squaredNorm();
  f.rmse = std::sqrt(ssr / static_cast<double>(n));
  f.r2 = r_squared(y.head(n), f.residuals);
  if (n > 2) {
    const Eigen::Matrix2d cov = (J.transpose() * J).inverse() * (ssr / static_cast<double>(n - 2));
    f.c1_se = std::sqrt(std::max(0.0, cov(0, 0)));
    f.c2_se = std::sqrt(std::max(0.0, cov(1, 1)));
  }
  return f;
}

Hysteresis hysteresis_eq1(const LineAccumulator& flexion, const LineAccumulator& extension) {
  Hysteresis h;
  if (!flexion.ok() || !extension.ok()) return h;
  const double lo = std::min(flexion.x_min, extension.x_min);
  const double hi = std::max(flexion.x_max, extension.x_max);
  h.x_mid = 0.5 * (lo + hi);
  h.y_flexion_mid = flexion.at(h.x_mid);
  h.y_extension_mid = extension.at(h.x_mid);
  const double ends[4] = {flexion.at(lo), flexion.at(hi), extension.at(lo), extension.at(hi)};
  h.span = *std::max_element(ends, ends + 4) - *std::min_element(ends, ends + 4);
  if (!(h.span > 0)) return h;
  h.pct = (h.y_extension_mid - h.y_flexion_mid) / h.span * 100.0;
  h.valid = std::isfinite(h.pct);
  return h;
}

}  // namespace pof::core

namespace pof::core {

namespace {
// Least squares restricted to the passive columns (the others are 0), on the scaled system.
Eigen::VectorXd solve_passive(const Eigen::MatrixXd& Gs, const Eigen::VectorXd& gs, const std::vector<bool>& passive) {
  const Eigen::Index p = Gs.rows();
  std::vector<Eigen::Index> idx;
  for (Eigen::Index i = 0; i < p; ++i)
    if (passive[static_cast<std::size_t>(i)]) idx.push_back(i);
  Eigen::VectorXd z = Eigen::VectorXd::Zero(p);
  const auto k = static_cast<Eigen::Index>(idx.size());
  if (k == 0) return z;
  Eigen::MatrixXd A(k, k);
  Eigen::VectorXd rhs(k);
  for (Eigen::Index r = 0; r < k; ++r) {
    rhs(r) = gs(idx[static_cast<std::size_t>(r)]);
    for (Eigen::Index c = 0; c < k; ++c) A(r, c) = Gs(idx[static_cast<std::size_t>(r)], idx[static_cast<std::size_t>(c)]);
  }
  A.diagonal().array() += 1e-10;
  const Eigen::VectorXd sol = A.ldlt().solve(rhs);
  for (Eigen::Index r = 0; r < k; ++r) z(idx[static_cast<std::size_t>(r)]) = sol(r);
  return z;
}
}  // namespace

bool nnls_normal(const Eigen::Ref<const Eigen::MatrixXd>& G, const Eigen::Ref<const Eigen::VectorXd>& g,
                 const std::vector<bool>& nonneg, Eigen::VectorXd& b) {
  const Eigen::Index p = G.rows();
  Eigen::VectorXd d(p);
  for (Eigen::Index i = 0; i < p; ++i) d(i) = G(i, i) > 1e-300 ? 1.0 / std::sqrt(G(i, i)) : 0.0;
  const Eigen::MatrixXd Gs = d.asDiagonal() * G * d.asDiagonal();
  const Eigen::VectorXd gs = d.asDiagonal() * g;
  std::vector<bool> passive(static_cast<std::size_t>(p));
  for (Eigen::Index i = 0; i < p; ++i) passive[static_cast<std::size_t>(i)] = !nonneg[static_cast<std::size_t>(i)];
  Eigen::VectorXd x = solve_passive(Gs, gs, passive);  // the free variables alone
  bool converged = false;
  for (Eigen::Index it = 0; it < 4 * p + 4; ++it) {
    // Outer loop: the constrained variable whose gradient most wants to grow joins the passive set.
    const Eigen::VectorXd w = gs - Gs * x;
    Eigen::Index j = -1;
    double best = 1e-12;
    for (Eigen::Index i = 0; i < p; ++i)
      if (nonneg[static_cast<std::size_t>(i)] && !passive[static_cast<std::size_t>(i)] && w(i) > best) {
        best = w(i);
        j = i;
      }
    if (j < 0) {
      converged = true;
      break;
    }
    passive[static_cast<std::size_t>(j)] = true;
    for (Eigen::Index inner = 0; inner <= p; ++inner) {
      // Inner loop: step towards the unconstrained solution on the passive set until it is feasible.
      const Eigen::VectorXd z = solve_passive(Gs, gs, passive);
      double alpha = 1.0;
      bool feasible = true;
      for (Eigen::Index i = 0; i < p; ++i)
        if (nonneg[static_cast<std::size_t>(i)] && passive[static_cast<std::size_t>(i)] && z(i) <= 0) {
          feasible = false;
          const double den = x(i) - z(i);
          if (den > 0) alpha = std::min(alpha, x(i) / den);
        }
      if (feasible) {
        x = z;
        break;
      }
      x += alpha * (z - x);
      for (Eigen::Index i = 0; i < p; ++i)
        if (nonneg[static_cast<std::size_t>(i)] && passive[static_cast<std::size_t>(i)] && x(i) <= 1e-15) {
          passive[static_cast<std::size_t>(i)] = false;
          x(i) = 0;
        }
    }
  }
  b = d.asDiagonal() * x;
  return converged;
}

Eigen::VectorXd one_signed_least_squares(const Eigen::Ref<const Eigen::MatrixXd>& G,
                                         const Eigen::Ref<const Eigen::VectorXd>& g, Eigen::Index first,
                                         Eigen::Index size) {
  const Eigen::Index p = G.rows();
  std::vector<bool> nonneg(static_cast<std::size_t>(p), false);
  for (Eigen::Index i = first; i < first + size; ++i) nonneg[static_cast<std::size_t>(i)] = true;
  Eigen::VectorXd best;
  double best_objective = std::numeric_limits<double>::infinity();
  for (const double sign : {1.0, -1.0}) {
    if (size == 0 && sign < 0) break;
    Eigen::VectorXd flip = Eigen::VectorXd::Ones(p);
    flip.segment(first, size).setConstant(sign);
    Eigen::VectorXd b;
    // Not converging leaves a feasible point: still scored.
    nnls_normal(flip.asDiagonal() * G * flip.asDiagonal(), flip.asDiagonal() * g, nonneg, b);
    b = flip.asDiagonal() * b;
    // The residual's sum of squares less y'y.
    const double objective = b.dot(G * b) - 2.0 * b.dot(g);
    if (objective < best_objective) {
      best_objective = objective;
      best = std::move(b);
    }
  }
  return best;
}

}  // namespace pof::core
