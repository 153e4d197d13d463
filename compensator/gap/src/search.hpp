#pragma once
// The model `pof gap` grows (baseline + accepted effects), its design matrix, and the evaluation of
// candidate effects against it (docs/gap.md, sections 3-4). Internal to pof_gap.
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "../effects/effect.hpp"
#include "cv.hpp"

namespace pof::gap {

struct Term {
  core::Effect effect;
  double theta = 0;  // the nonlinear parameter (tau, frequency); 0 for effects without one
};

/// The model so far: kinematic parameters and the accepted voltage terms, in acceptance order.
struct State {
  double delay_s = 0;
  double backlash_deg = 0;
  std::vector<Term> terms;
  [[nodiscard]] bool has(core::Effect e) const;
  /// State with effect e at theta added.
  [[nodiscard]] State with(core::Effect e, double theta) const;
  [[nodiscard]] std::size_t size() const { return terms.size() + (delay_s != 0 ? 1 : 0) + (backlash_deg > 0 ? 1 : 0); }
};

/// Everything the search shares: the recording, the baseline, the folds.
struct Search {
  Context cx;
  cv::Blocks blocks;
};

/// y = v - v0 (the baseline voltage) regressed on X = [baseline columns | term columns]. The
/// paper structure's coefficients move to first order around the refitted model (its gradient,
/// pof/core/paper_refit.hpp); the dynamic model is linear in its coefficients, its columns are its
/// regressors (pof/core/dynamic_fit.hpp) and a move is exact. The terms enter linearly.
struct Design {
  Kinematics k;
  Eigen::MatrixXd X;
  Eigen::VectorXd y;
};

/// The number of baseline columns: the paper structure's refit parameters or the dynamic model's
/// linear coefficients.
Eigen::Index base_cols(const Context& cx);

/// The kinematics of the reference angle seen through a delay and a belt play.
Kinematics baseline_kinematics(const Context& cx, double delay_s, double backlash_deg);

/// The design of state st: y = v - the baseline simulator's voltage at st's kinematics, X = the
/// simulator's gradient in the structure's coefficients (base_cols), then each term's columns.
Design build_design(const Search& sx, const State& st);
/// The same with st's kinematics given: k must be baseline_kinematics(sx.cx, st.delay_s,
/// st.backlash_deg), computed once where many designs share them (a grid over a term's theta,
/// over a belt play at one delay).
Design build_design(const Search& sx, const State& st, Kinematics k);

/// The baseline structure at some coefficients: the paper's (always there: f5 gives the quiet
/// angle and the sensitivity) and the dynamic model when it is the baseline (what the compensator
/// then inverts, docs/calibration.md).
struct Structure {
  core::ModelCoefficients paper;
  std::optional<core::DynamicModel> dynamic;
};

/// A moved structure's branches may depart from the fitted baseline's by its own hysteresis, and
/// by at least this [deg] (the paper's table 2 has ~3 deg; see moved_model in search.cpp).
inline constexpr double kMinStructureMoveDeg = 3.0;

/// How far a move may take the baseline from its origin [deg]: its own hysteresis (the paper
/// structure's largest branch offset from f5 up to 1.5x the recording's speeds, or the dynamic
/// model's largest departure from its quasi-static curve over the recording), at least
/// kMinStructureMoveDeg. Depends on the origin only: computed once into Context::move_limit_deg.
double structure_move_limit(const Context& cx);

/// The baseline's coefficients moved by the first base_cols values of a solution beta, within
/// bounds (see moved_model in search.cpp; the limit is cx.move_limit_deg).
Structure moved_structure(const Context& cx, const Eigen::VectorXd& beta);

/// sx with the baseline's coefficients moved by the first base_cols values of a solution beta.
Search moved(const Search& sx, const Eigen::VectorXd& beta);

/// Why effect e is no candidate on this baseline, or "": the dynamic model's Prony terms are a
/// relaxation, its polynomial a static nonlinearity (its stop operators are a memory hysteresis, so
/// there memory_hysteresis is offered only as relays, which they cannot draw). Beside
/// them such a term draws the same curve: the fit splits it between the two, and a move of the
/// structure shortened by its bounds (moved_dynamic) leaves the term's share applied alone, which
/// makes the online angle worse than no term (docs/gap.md, section 1, "The dynamic structure in the
/// design").
std::string covered_by_baseline(core::Effect e, const Context& cx);


struct CurrentFit {
  Design d;
  cv::Grams grams;
  cv::FoldFit fit;          // a grid of size 1 (the state is fixed)
  Eigen::VectorXd cv_resid; // held-out residual [V], block by block
};

CurrentFit fit_state(const Search& sx, const State& st);
/// The same with st's kinematics given (as build_design's).
CurrentFit fit_state(const Search& sx, const State& st, Kinematics k);

/// Held-out residual of design d with one coefficient vector per block.
Eigen::VectorXd heldout_residual(const Design& d, const cv::Blocks& b, const std::vector<Eigen::VectorXd>& beta);

/// "Add and refit" (docs/gap.md, section 4): re-chooses the nonlinear parameters of the accepted
/// terms on all data with the others fixed (one coordinate pass). resid: the current held-out
/// residual [V], for grids that look at it; the values are scored on `threads` workers.
void refit_thetas(const Search& sx, State& st, const Eigen::VectorXd& resid, int threads);

/// On the dynamic baseline: re-chooses the model's rate gain kappa (core::fit_dynamic's grid) on
/// all data with the accepted terms in. Fitted without them, kappa imitates what they explain (a
/// gain of 1 s/rad took part of a fibre's acceleration dependence); once the term holds that, the
/// stale kappa leaves a speed-proportional residual for the next candidate to take. The gains are
/// scored on `threads` workers.
void refit_rate_gain(Search& sx, const State& st, int threads);

struct CandidateResult {
  core::Effect effect;
  bool eligible = true;  // tried on this recording (else `note` says why not)
  std::string note;
  std::vector<double> grid;
  cv::FoldFit fit;
  int n_params = 0;
  Structure base;  // the baseline the fit's columns were built at (see evaluate)
  /// Kinematic candidates: the held-out RSS per fold at each value of `profile_grid` held fixed
  /// (cv::heldout_profile), to say which values the recording cannot tell apart.
  std::vector<double> profile_grid;
  std::vector<std::vector<double>> profile;
};

/// One candidate of the catalogue against the current fit (its grid, refinement and rescoring).
CandidateResult evaluate(core::Effect e, const Search& sx, const State& st, const CurrentFit& cur);
/// Every candidate of the catalogue against the current fit, on `threads` workers.
std::vector<CandidateResult> evaluate_all(const Search& sx, const State& st, const CurrentFit& cur, int threads);

}  // namespace pof::gap
