// Time-blocked cross-validation (see cv.hpp).
#include "cv.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "pof/core/fit.hpp"

namespace pof::gap::cv {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

// A design with a non-finite value (a moved structure outside its domain) scores as the worst fit,
// never as a perfect one (std::max(0, NaN) would be 0).
double rss_of(double yy, const VectorXd& g, const MatrixXd& G, const VectorXd& beta) {
  const double r = yy - 2.0 * beta.dot(g) + beta.dot(G * beta);
  return std::isfinite(r) ? std::max(0.0, r) : kInf;
}

double lag1(const VectorXd& r) {
  const double m = r.mean();
  const VectorXd c = r.array() - m;
  const double den = c.squaredNorm();
  if (den <= 0) return 0;
  return c.head(c.size() - 1).dot(c.tail(c.size() - 1)) / den;
}
}  // namespace

// K x m contiguous blocks dealt to the folds in turn (cv.hpp). Each boundary is moved to the nearest
// hold scan so no movement (and so no cycle) is cut in two: the folds are time blocks of whole
// cycles, never random samples (docs/gap.md, section 4).
Blocks make_blocks(const Kinematics& k, int folds, double dt, double block_s) {
  const Index n = k.w.size();
  const auto nf = static_cast<Index>(folds);
  const double duration = static_cast<double>(n) * dt;
  const Index per_fold = block_s > 0 ? std::max<Index>(1, std::lround(duration / (static_cast<double>(nf) * block_s))) : 1;
  const Index nb = nf * per_fold;
  std::vector<Index> cut{0};
  for (Index f = 1; f < nb; ++f) {
    const Index target = f * n / nb;
    const Index reach = n / (2 * nb);
    Index best = target;
    for (Index d = 0; d <= reach; ++d) {
      if (target + d < n && k.s_move(target + d) == 0) { best = target + d; break; }
      if (target - d >= 0 && k.s_move(target - d) == 0) { best = target - d; break; }
    }
    if (best > cut.back() + 10) cut.push_back(best);
  }
  cut.push_back(n);
  Blocks b;
  b.folds.resize(static_cast<std::size_t>(std::min<Index>(nf, static_cast<Index>(cut.size()) - 1)));
  for (std::size_t i = 0; i + 1 < cut.size(); ++i)
    b.folds[i % b.folds.size()].push_back({cut[i], cut[i + 1] - cut[i]});
  return b;
}

// ---- least squares on per-block normal equations -------------------------------------------------
Grams make_grams(const MatrixXd& X, const VectorXd& y, const Blocks& b) {
  Grams gr;
  for (std::size_t i = 0; i < b.size(); ++i) {
    MatrixXd G = MatrixXd::Zero(X.cols(), X.cols());
    VectorXd g = VectorXd::Zero(X.cols());
    double yy = 0;
    for (const Span& sp : b.folds[i]) {
      const auto Xb = X.middleRows(sp.start, sp.len);
      const auto yb = y.segment(sp.start, sp.len);
      G.selfadjointView<Eigen::Lower>().rankUpdate(Xb.transpose());
      g += Xb.transpose() * yb;
      yy += yb.squaredNorm();
    }
    gr.G.push_back(G.selfadjointView<Eigen::Lower>());
    gr.g.push_back(std::move(g));
    gr.yy.push_back(yy);
  }
  return gr;
}

// Base grams extended by new columns C (only the new cross products are computed).
Grams extend_grams(const Grams& base, const MatrixXd& X0, const MatrixXd& C, const VectorXd& y, const Blocks& b) {
  Grams gr;
  const Index k0 = X0.cols(), c = C.cols();
  for (std::size_t i = 0; i < b.size(); ++i) {
    MatrixXd G(k0 + c, k0 + c);
    G.topLeftCorner(k0, k0) = base.G[i];
    G.topRightCorner(k0, c).setZero();
    G.bottomRightCorner(c, c).setZero();
    VectorXd g(k0 + c);
    g.head(k0) = base.g[i];
    g.tail(c).setZero();
    for (const Span& sp : b.folds[i]) {
      const auto X0b = X0.middleRows(sp.start, sp.len);
      const auto Cb = C.middleRows(sp.start, sp.len);
      const auto yb = y.segment(sp.start, sp.len);
      G.topRightCorner(k0, c) += X0b.transpose() * Cb;
      G.bottomRightCorner(c, c) += Cb.transpose() * Cb;
      g.tail(c) += Cb.transpose() * yb;
    }
    G.bottomLeftCorner(c, k0) = G.topRightCorner(k0, c).transpose();
    gr.G.push_back(std::move(G));
    gr.g.push_back(std::move(g));
    gr.yy.push_back(base.yy[i]);
  }
  return gr;
}

Grams select_columns(const Grams& g, Index k0, const std::vector<Index>& extra) {
  std::vector<Index> idx(static_cast<std::size_t>(k0));
  for (Index i = 0; i < k0; ++i) idx[static_cast<std::size_t>(i)] = i;
  for (Index e : extra) idx.push_back(k0 + e);
  Grams out;
  for (std::size_t b = 0; b < g.G.size(); ++b) {
    out.G.emplace_back(g.G[b](idx, idx));
    out.g.emplace_back(g.g[b](idx));
    out.yy.push_back(g.yy[b]);
  }
  return out;
}

// Jacobi-scaled LDLT with a tiny ridge: a column that is all zeros (an input that never varies)
// gets a zero coefficient instead of a NaN.
VectorXd solve(const MatrixXd& G, const VectorXd& g) {
  const Index k = G.rows();
  VectorXd d(k);
  for (Index i = 0; i < k; ++i) d(i) = G(i, i) > 1e-300 ? 1.0 / std::sqrt(G(i, i)) : 0.0;
  MatrixXd Gs = d.asDiagonal() * G * d.asDiagonal();
  Gs.diagonal().array() += 1e-10;
  const VectorXd bs = Gs.ldlt().solve(d.asDiagonal() * g);
  return d.asDiagonal() * bs;
}

VectorXd solve_one_signed(const MatrixXd& G, const VectorXd& g, Index first, Index size) {
  const VectorXd free_fit = solve(G, g);
  const auto part = free_fit.segment(first, size).array();
  if ((part >= 0).all() || (part <= 0).all()) return free_fit;  // the constrained optimum as well
  return core::one_signed_least_squares(G, g, first, size);
}

namespace {
// Least squares with the first `shared` coefficients fixed at b_shared: G_uu u = g_u - G_us b_s.
VectorXd solve_with_shared(const MatrixXd& G, const VectorXd& g, const VectorXd& full, Index shared) {
  if (shared == 0) return solve(G, g);
  const Index k = G.rows(), u = k - shared;
  VectorXd beta(k);
  beta.head(shared) = full.head(shared);
  if (u > 0)
    beta.tail(u) = solve(G.bottomRightCorner(u, u), g.tail(u) - G.bottomLeftCorner(u, shared) * full.head(shared));
  return beta;
}
}  // namespace

FoldFit cross_validate(const std::vector<Grams>& per_theta, Index shared) {
  FoldFit ff;
  const std::size_t nb = per_theta.front().G.size();
  std::vector<MatrixXd> Gt(per_theta.size());
  std::vector<VectorXd> gt(per_theta.size());
  std::vector<double> yt(per_theta.size());
  for (std::size_t t = 0; t < per_theta.size(); ++t) {
    Gt[t] = per_theta[t].G[0];
    gt[t] = per_theta[t].g[0];
    yt[t] = per_theta[t].yy[0];
    for (std::size_t b = 1; b < nb; ++b) {
      Gt[t] += per_theta[t].G[b];
      gt[t] += per_theta[t].g[b];
      yt[t] += per_theta[t].yy[b];
    }
  }
  ff.full_rss = kInf;
  std::vector<VectorXd> full(per_theta.size());
  for (std::size_t t = 0; t < per_theta.size(); ++t) {
    full[t] = solve(Gt[t], gt[t]);
    const double r = rss_of(yt[t], gt[t], Gt[t], full[t]);
    if (r < ff.full_rss) { ff.full_rss = r; ff.full_idx = t; ff.beta_full = full[t]; }
  }
  for (std::size_t f = 0; f < nb; ++f) {
    double best = kInf;
    std::size_t bi = 0;
    VectorXd bb;
    for (std::size_t t = 0; t < per_theta.size(); ++t) {
      const MatrixXd G = Gt[t] - per_theta[t].G[f];
      const VectorXd g = gt[t] - per_theta[t].g[f];
      const double yy = yt[t] - per_theta[t].yy[f];
      const VectorXd beta = solve_with_shared(G, g, full[t], shared);
      const double r = rss_of(yy, g, G, beta);
      if (r < best) { best = r; bi = t; bb = beta; }
    }
    const double h = rss_of(per_theta[bi].yy[f], per_theta[bi].g[f], per_theta[bi].G[f], bb);
    ff.theta_idx.push_back(bi);
    ff.beta.push_back(bb);
    ff.cv_rss += h;
  }
  return ff;
}

std::vector<std::vector<double>> heldout_profile(const std::vector<Grams>& per_theta, Index shared) {
  std::vector<std::vector<double>> out;
  for (const Grams& gr : per_theta) {
    const std::size_t nb = gr.G.size();
    MatrixXd G = gr.G[0];
    VectorXd g = gr.g[0];
    double yy = gr.yy[0];
    for (std::size_t b = 1; b < nb; ++b) { G += gr.G[b]; g += gr.g[b]; yy += gr.yy[b]; }
    const VectorXd full = solve(G, g);
    std::vector<double> folds;
    for (std::size_t f = 0; f < nb; ++f) {
      const VectorXd beta = solve_with_shared(G - gr.G[f], g - gr.g[f], full, shared);
      folds.push_back(rss_of(gr.yy[f], gr.g[f], gr.G[f], beta));
    }
    out.push_back(std::move(folds));
  }
  return out;
}

double effective_n(const VectorXd& r) {
  const double rho = std::clamp(lag1(r), 0.0, 0.999);
  return std::max(50.0, static_cast<double>(r.size()) * (1 - rho) / (1 + rho));
}

}  // namespace pof::gap::cv
