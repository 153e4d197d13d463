#pragma once
// Closing the loop in the report: the angle the compensator would output with the baseline alone
// and with the found model, against the reference, on held-out blocks (docs/gap.md, section 5).
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pof/core/gap_terms.hpp"
#include "pof/io/recording.hpp"
#include "search.hpp"

namespace pof::gap {

/// The state's effect terms as the compensator's GapModel (docs/calibration.md, "[gap]"), with the
/// coefficients of beta (after the base_cols baseline columns, in term order).
core::GapModel gap_model_of(const State& st, const Eigen::VectorXd& beta, const Context& cx);

/// The model the compensator is given for a fitted state: the baseline structure as moved (the
/// search's step, then damped Gauss-Newton beside the terms, each step within its bounds:
/// moved_structure) and the terms' coefficients least-squares on the voltage that
/// structure leaves, fold by fold on the training blocks and once on every block (docs/gap.md,
/// section 5). The search's fit moves the structure to first order beside the terms; a move its
/// bounds shorten leaves the terms fitted beside a structure that is not the one applied.
struct AppliedFit {
  Context cx;                          // the search's context at the structure applied (for the terms' units)
  std::vector<Eigen::VectorXd> beta;   // per fold: zeros for the structure's columns, then the terms'
  Eigen::VectorXd beta_full;
  [[nodiscard]] Structure structure() const { return {cx.m, cx.dyn}; }
};
AppliedFit applied_fit(const Search& sx, const State& st, const CurrentFit& after);
/// The model applied when nothing found can be applied (no term, delay or play): structure m as
/// it is, no coefficients.
AppliedFit applied_baseline(const Search& sx, const Structure& m);

/// The part of state st the compensator can apply: st without the terms it refuses
/// (core::gap_problems, judged at the search's fit `cur`: a drift, a trend over this recording, has
/// no online form), and the refused effects' ids, each named once. The model applied is fitted
/// without them (applied_fit on `state`): fitted beside a drift column and then applied without
/// it, the structure loses the share of the trend its own offset had taken, and the angle gets
/// worse than the baseline's (measured: docs/gap.md, section 5, "model.toml").
struct OnlinePart {
  State state;
  std::vector<std::string> refused;
};
OnlinePart online_part(const State& st, const CurrentFit& cur, const Context& cx, double rate_hz);

/// Which of a state's effects are applied: the kinematic ones and each voltage term (in order).
struct Applied {
  bool delay = true, backlash = true;
  std::vector<bool> terms;
};

/// What compensated_rmse scores: the recording, the search whose folds and signals it uses, the
/// baseline (`before`: its all-data fit; the dynamic model when it is the baseline), the state's
/// part the compensator applies (`st`, online_part) and its fit (`after`: the baseline moved and
/// the terms' coefficients per fold), the refused effects' ids, and the scans near the reference's
/// transitions (transition_scans).
struct CompensationInputs {
  const io::Recording& rec;
  const Search& sx;
  const Structure& before;
  const State& st;
  const AppliedFit& after;
  const std::vector<std::string>& not_applied;
  const std::vector<bool>& transition;
  int threads = 1;  // the folds' compensator runs are spread over this many workers
};

/// The report's "compensated" section, which of the state's effects model.toml may hold, and the
/// compensator's angle over the recording with the baseline and (block by block, the model fitted
/// on the other blocks) with every effect applied.
struct CompensatedScores {
  nlohmann::json report;
  Applied written;
  Eigen::VectorXd angle_before, angle_after;
};

/// Runs core::OnlineCompensator over the recording with the baseline and, fold by fold, with the
/// model fitted on the other folds, and scores each fold's held-out block against the reference
/// angle: RMSE before and after, per fold and overall. `st` holds only terms the compensator
/// applies; those it refused are named in "not_applied". Then each effect is left out in turn;
/// those whose online application makes the held-out angle worse are left out of `written` (not to
/// be written to model.toml) and listed in "left_out_of_model"; "model_toml_nested" makes that
/// choice (and model.toml's fallback to the baseline) for each block from the other blocks alone
/// and scores it on that block (docs/gap.md, section 5, "What model.toml holds").
///
/// The same RMSEs are also reported without the scans of `transition` ("steady"): the paper
/// model's inverse decides flexion, extension or hold from a velocity estimate that needs its
/// window to see a start, stop or reversal, and until then reads the wrong branch (the step
/// model's spikes). Those errors are the baseline's, the same before and after, and no effect
/// term acts on them; the steady figures show what the found model changes everywhere else.
CompensatedScores compensated_rmse(const CompensationInputs& in);

/// The calibration the compensator runs for a structure: the dynamic model, when there is one,
/// active (inverted online), the paper structure otherwise; range and normalisation from s.
core::Calibration calibration_of(const Structure& m, const Signals& s);

/// Scans within window_s after the reference's direction changes (hold -> moving, moving -> hold,
/// flexion <-> extension; Kinematics::s_move).
std::vector<bool> transition_scans(const Kinematics& k, double dt, double window_s);

}  // namespace pof::gap
