#pragma once
// Time-blocked cross-validation on per-block normal equations (docs/gap.md, section 4): the folds,
// the least-squares pieces and the effective sample size of an autocorrelated residual. Internal to
// pof_gap.
#include <vector>

#include <Eigen/Core>

#include "pof/gap/signals.hpp"

namespace pof::gap::cv {

/// Scans [start, start + len).
struct Span {
  Eigen::Index start = 0, len = 0;
};

/// The folds: each is a set of contiguous time blocks (spans) held out together.
struct Blocks {
  std::vector<std::vector<Span>> folds;
  [[nodiscard]] std::size_t size() const { return folds.size(); }
};

/// `folds` x m contiguous blocks whose boundaries are moved to the nearest hold scan, so no
/// movement (and so no cycle) is cut in two, dealt to the folds in turn: block j goes to fold
/// j mod `folds`. m = round(duration / (folds x block_s)), at least 1 (m = 1: each fold one block).
/// Time blocks of whole cycles, never random samples; dealt out so that every fold's training
/// blocks hold every kind of movement the session has (docs/gap.md, section 4).
Blocks make_blocks(const Kinematics& k, int folds, double dt, double block_s);

/// Per-block normal equations X'X, X'y and y'y.
struct Grams {
  std::vector<Eigen::MatrixXd> G;
  std::vector<Eigen::VectorXd> g;
  std::vector<double> yy;
};

Grams make_grams(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const Blocks& b);
/// Base grams extended by new columns C (only the new cross products are computed).
Grams extend_grams(const Grams& base, const Eigen::MatrixXd& X0, const Eigen::MatrixXd& C, const Eigen::VectorXd& y,
                   const Blocks& b);

/// The grams of the first k0 columns and, after them, the listed ones of those that follow (counted
/// from k0): the normal equations of the design with only those columns.
Grams select_columns(const Grams& g, Eigen::Index k0, const std::vector<Eigen::Index>& extra);

/// Jacobi-scaled LDLT with a tiny ridge: a column that is all zeros gets a zero coefficient.
Eigen::VectorXd solve(const Eigen::MatrixXd& G, const Eigen::VectorXd& g);

/// Least squares (as solve) with the coefficients [first, first + size) all of one sign, whichever
/// fits better (core::one_signed_least_squares); a solution already of one sign there is solve's.
Eigen::VectorXd solve_one_signed(const Eigen::MatrixXd& G, const Eigen::VectorXd& g, Eigen::Index first,
                                 Eigen::Index size);

struct FoldFit {
  std::vector<std::size_t> theta_idx;  // per fold: grid index chosen on the training blocks
  std::vector<Eigen::VectorXd> beta;   // per fold
  double cv_rss = 0;                   // sum of held-out RSS
  std::size_t full_idx = 0;            // grid index minimising the all-data RSS
  Eigen::VectorXd beta_full;
  double full_rss = 0;
};

/// Blocked CV over a grid of nonlinear parameters (one Grams per grid value): for each fold the grid
/// value and the linear coefficients are chosen on the training blocks only; the held-out block
/// only scores. The first `shared` coefficients (the baseline structure's) are the exception: they
/// are fitted on all data (jointly with the others, per grid value) and held fixed in the folds. A
/// structure of 11 coefficients fitted on >10^4 scans leaks little, whereas refitting it per fold
/// would extrapolate it into whatever the held-out block alone contains (the fastest movements, the
/// gait) and report that as a gap.
FoldFit cross_validate(const std::vector<Grams>& per_theta, Eigen::Index shared = 0);

/// The held-out RSS of each fold at each grid value held fixed (not chosen per fold), the shared
/// coefficients fitted on all data as in cross_validate: the profile of the held-out error over
/// theta, [grid value][fold].
std::vector<std::vector<double>> heldout_profile(const std::vector<Grams>& per_theta, Eigen::Index shared = 0);

/// Effective number of independent residuals (AR(1) approximation) for the BIC.
double effective_n(const Eigen::VectorXd& r);

}  // namespace pof::gap::cv
