// The compensated angle before and after the found model (see compensation.hpp).
#include "compensation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "pof/core/calibration.hpp"
#include "pof/core/compensator.hpp"
#include "pof/core/dynamic_model.hpp"
#include "pof/core/estimator_noise.hpp"
#include "pof/core/fit.hpp"
#include "pof/core/gap_terms.hpp"
#include "pof/core/model.hpp"
#include "pof/core/units.hpp"

#include "parallel.hpp"

namespace pof::gap {

using Eigen::Index;
using Eigen::VectorXd;

core::GapModel gap_model_of(const State& st, const VectorXd& beta, const Context& cx) {
  core::GapModel g;
  g.delay_s = st.delay_s;
  g.backlash_deg = st.backlash_deg;
  Index c = base_cols(cx);
  for (const Term& t : st.terms) {
    const EffectDef& def = effect_def(t.effect);
    core::GapTerm term;
    term.effect = std::string(core::to_string(t.effect));
    term.theta = def.theta_in_file ? t.theta : 0.0;
    const int linear = linear_columns(def, cx);
    for (Index i = 0; i < linear; ++i) term.coefficients_v.push_back(beta(c + i));
    term.coefficients_v.resize(static_cast<std::size_t>(std::max(linear, def.file_coefficients)), 0.0);
    if (def.write_basis != nullptr) def.write_basis(t.theta, cx, term);
    const nlohmann::json p = def.physical(t.theta, beta.segment(c, linear), cx);
    for (auto it = p.begin(); it != p.end(); ++it) term.parameters.emplace_back(it.key(), it.value().get<double>());
    g.terms.push_back(std::move(term));
    c += linear;
  }
  return g;
}

namespace {

// The acceleration the compensator estimates at each scan (rad/s^2): the causal quadratic fit
// over the n angles before it (GapCorrector: the estimate made when a scan's angle is committed
// serves the next scan), 0 until n angles are in.
VectorXd causal_acceleration(const VectorXd& angle_deg, int n, double dt) {
  const std::vector<double> w = core::acceleration_weights(n, dt);
  VectorXd a = VectorXd::Zero(angle_deg.size());
  for (Index k = n; k < angle_deg.size(); ++k)
    a(k) = core::acceleration_estimate(w, [&](std::size_t back) { return angle_deg(k - 1 - static_cast<Index>(back)); }) *
           core::kRadPerDeg;
  return a;
}

// Gauss-Newton rounds of the structure beside the terms (the first takes the step of the fit
// applied_fit is given), and the relative decrease of the residual under which they stop: the
// decrease shrinks from round to round, so a round that buys < 0.1 % ends them, and the cap only
// bounds the cost (rounds counted on a blind recording: docs/gap.md, section 5, applied_fit).
constexpr int kMaxStructureRounds = 12;
constexpr double kStructureRoundGain = 1e-3;

// The sum of squares the terms alone leave at the structure of x (their least squares on every
// block): the nonlinear objective the structure's moves must decrease.
double terms_residual(const Search& x, const State& st) {
  const Design d = build_design(x, st);
  const Index nt = d.X.cols() - base_cols(x.cx);
  if (nt == 0) return d.y.squaredNorm();  // kinematics alone (delay, play): no coefficient to fit
  return cv::cross_validate({cv::make_grams(d.X.rightCols(nt), d.y, x.blocks)}, 0).full_rss;
}

}  // namespace

AppliedFit applied_fit(const Search& sx, const State& st, const CurrentFit& after) {
  AppliedFit a;
  // The structure's coefficients are fitted on every block and shared by the folds
  // (cv::cross_validate), so the moves below serve them all.
  //
  // The search moves the structure by first-order steps beside the terms (a few, undamped), the
  // last of them in `after`. Along a direction the voltage barely tells from a term (the paper
  // structure's hysteresis against a relaxation or a memory term that draws the same loop) a
  // first-order step runs to branches far off f5, and moved_structure halves it back within its
  // bounds, often to a small fraction. Beside a structure moved that little, the terms are
  // refitted to the share of the effect the baseline had not already absorbed in its hysteresis,
  // not to the sensor's whole effect, and the compensated angle keeps much of its error. So the
  // structure goes on by damped Gauss-Newton: relinearised where the last step landed, structure
  // and terms fitted jointly, and the step halved until the residual the terms leave at the moved
  // structure decreases (a round without a decrease ends the search). Undamped, the steps
  // oscillate along the same near-degenerate direction. Measured on blind recordings: docs/gap.md,
  // section 5 (applied_fit).
  Search at = sx;
  double residual = terms_residual(at, st);
  VectorXd step = after.fit.beta_full;
  for (int round = 0; round < kMaxStructureRounds; ++round) {
    if (round > 0) step = fit_state(at, st).fit.beta_full;
    const double before = residual;
    auto taken = core::halving_search([&](double scale) -> std::optional<std::pair<Search, double>> {
      Search moved_at = moved(at, scale * step);
      if (const double r = terms_residual(moved_at, st); r < before) return std::pair{std::move(moved_at), r};
      return std::nullopt;
    });
    if (taken) {
      at = std::move(taken->first);
      residual = taken->second;
    }
    if (!(residual < (1 - kStructureRoundGain) * before)) break;
  }
  a.cx = at.cx;
  Design d = build_design(at, st);
  const Index nb = base_cols(at.cx), nt = d.X.cols() - nb;
  if (nt == 0) {  // only the kinematics (delay, play) or nothing: no coefficients to fit
    a.beta.assign(sx.blocks.size(), VectorXd::Zero(nb));
    a.beta_full = VectorXd::Zero(nb);
    return a;
  }
  // A memory term's stop-operator (or relay-knot) weights are held to one sign, whichever fits better: with
  // weights of one sign every loop, major or minor, runs the same way round (docs/calibration.md,
  // "Why stop operators"); a weight against the others draws loops that run the other way, a
  // Maxwell-slip element of negative stiffness, which no fibre is taken to have. Least squares on
  // the reference's angle makes such weights up all the same, and applied online they made the
  // held-out angle worse (docs/gap.md, section 5). The state holds each effect at most once.
  Index memory_first = 0, memory_size = 0;
  for (Index c = 0; const Term& t : st.terms) {
    const EffectDef& def = effect_def(t.effect);
    if (t.effect == core::Effect::kMemoryHysteresis) { memory_first = c; memory_size = def.linear; }
    c += linear_columns(def, at.cx);
  }
  auto fit_without = [&](const cv::Grams& gr, std::size_t skip) {
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(nt, nt);
    VectorXd g = VectorXd::Zero(nt);
    for (std::size_t b = 0; b < gr.G.size(); ++b)
      if (b != skip) { G += gr.G[b]; g += gr.g[b]; }
    VectorXd beta = VectorXd::Zero(nb + nt);
    beta.tail(nt) = cv::solve_one_signed(G, g, memory_first, memory_size);
    return beta;
  };
  // The search's acceleration column is centred (+-h on the reference angle); the compensator's
  // estimate is causal and, to keep its noise bounded, often longer, so it lags by half its window
  // and a scan. Fitted on the centred column, the coefficient is the physical one, and applied
  // with that lag it pulls the angle the wrong way wherever the acceleration changes within it (in
  // gait cycles: +-5 deg). So its column is the compensator's own estimate on the angle it
  // estimates it on, with the window the compensator will take for the coefficient
  // fitted on it (the coefficient sets the window and the other terms' voltage the angle: fitted
  // four rounds; each fold's compensator takes the window its own coefficient sets, which may
  // differ by a scan).
  struct Causal {
    Index col;
    double theta;
    int n = 0;
  };
  std::vector<Causal> causal;
  Index col = nb;
  for (const Term& t : st.terms) {
    if (t.effect == core::Effect::kAccelerationDependence) causal.push_back({col, t.theta});
    col += linear_columns(effect_def(t.effect), at.cx);
  }
  const double rate = 1.0 / at.cx.s->dt;
  // The angle the compensator estimates it on, on either baseline: the quiet angle, f5 of the
  // voltage after the other terms (core::OnlineCompensator's quiet chain). f5 has no branches, so
  // wherever the sensor's loop turns (every start, stop and reversal) that angle has a corner the
  // joint has not, and its second difference an acceleration the joint has not; fitted on the
  // joint's angle, the coefficient applied to those corners moved the angle +-5 deg in gait. On
  // the angle it will see, least squares weighs the corners in.
  const VectorXd& v = at.cx.s->v;
  auto quiet = [&](const VectorXd& beta) {
    VectorXd g = d.X.rightCols(nt) * beta.tail(nt);
    for (const Causal& c : causal) g -= d.X.col(c.col) * beta(c.col);
    return VectorXd((v - g).unaryExpr([&](double x) { return core::quasi_static_angle(at.cx.m, x); }));
  };
  VectorXd beta = VectorXd::Zero(nb + nt);
  cv::Grams gr = cv::make_grams(d.X.rightCols(nt), d.y, sx.blocks);
  for (int round = 0; round < 4 && !causal.empty(); ++round) {
    if (round > 0) beta = fit_without(gr, sx.blocks.size());
    const VectorXd seen = quiet(beta);
    for (Causal& c : causal) {
      c.n = core::acceleration_window_scans(round > 0 ? beta(c.col) : 0.0, c.theta, at.cx.m.c9, rate);
      d.X.col(c.col) = causal_acceleration(seen, c.n, at.cx.s->dt);
    }
    gr = cv::make_grams(d.X.rightCols(nt), d.y, sx.blocks);
  }
  for (std::size_t f = 0; f < sx.blocks.size(); ++f) a.beta.push_back(fit_without(gr, f));
  a.beta_full = fit_without(gr, sx.blocks.size());
  return a;
}

AppliedFit applied_baseline(const Search& sx, const Structure& m) {
  AppliedFit a;
  a.cx = sx.cx;
  a.cx.m = m.paper;
  a.cx.dyn = m.dynamic;
  a.beta.assign(sx.blocks.size(), VectorXd::Zero(base_cols(a.cx)));
  a.beta_full = VectorXd::Zero(base_cols(a.cx));
  return a;
}

namespace {

// The compensator's angle over the whole recording (its memory runs through every block).
VectorXd compensate(const io::Recording& rec, const core::Calibration& cal, double rate_hz) {
  core::CompensatorSettings cs;
  cs.scan_rate_hz = rate_hz;
  core::OnlineCompensator comp(cal, cs);
  VectorXd out(rec.size());
  for (Index i = 0; i < rec.size(); ++i) out(i) = comp.step(rec.sensor_v(i), rec.reference_v(i)).angle_deg;
  return out;
}

// The sum of squares of the angle a against the reference over a fold's scans with an angle, and
// how many scans that is.
void squared_error(const VectorXd& a, const VectorXd& ref, const std::vector<cv::Span>& fold, double& ss, Index& n) {
  ss = 0;
  n = 0;
  for (const cv::Span& sp : fold)
    for (Index i = sp.start; i < sp.start + sp.len; ++i)
      if (std::isfinite(a(i))) { ss += (a(i) - ref(i)) * (a(i) - ref(i)); ++n; }
}

double rms_of(const VectorXd& a, const VectorXd& ref, const std::vector<cv::Span>& fold) {
  double ss = 0;
  Index n = 0;
  squared_error(a, ref, fold, ss, n);
  return n > 0 ? std::sqrt(ss / static_cast<double>(n)) : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

namespace {

struct HeldOut {
  double rmse_deg = 0;
  nlohmann::json folds = nlohmann::json::array();
  VectorXd angle;  // block by block, the angle of the model fitted on the other blocks
  std::vector<double> ss;  // per block: the sum of squared angle errors and the scans it counts
  std::vector<Index> count;

  /// The RMSE over every block but `skip` (the blocks a nested choice for block `skip` may see).
  [[nodiscard]] double rmse_without_block(std::size_t skip) const {
    double s = 0;
    Index n = 0;
    for (std::size_t f = 0; f < ss.size(); ++f)
      if (f != skip) { s += ss[f]; n += count[f]; }
    return n > 0 ? std::sqrt(s / static_cast<double>(n)) : std::numeric_limits<double>::quiet_NaN();
  }
};

// The sums of squares of the angle a against the reference over each block.
void score_blocks(HeldOut& h, const VectorXd& a, const VectorXd& ref, const cv::Blocks& blocks) {
  h.ss.assign(blocks.size(), 0.0);
  h.count.assign(blocks.size(), 0);
  for (std::size_t f = 0; f < blocks.size(); ++f) squared_error(a, ref, blocks.folds[f], h.ss[f], h.count[f]);
}

// The compensator's angle with the state's terms (those `use` keeps; the state holds none the
// compensator refuses, see online_part), fold by fold with the model fitted on the other
// folds, scored on the held-out blocks.
HeldOut held_out(const io::Recording& rec, const Search& sx, const State& st, const AppliedFit& after,
                 const Applied& use, const VectorXd& a0, int threads) {
  const Signals& s = *sx.cx.s;
  const double rate = 1.0 / s.dt;
  std::vector<VectorXd> per_fold(sx.blocks.size());
  parallel_for(per_fold.size(), threads, [&](std::size_t f) {
    core::Calibration cal = calibration_of(after.structure(), s);
    core::GapModel g = gap_model_of(st, after.beta[f], after.cx);
    if (!use.delay) g.delay_s = 0;
    if (!use.backlash) g.backlash_deg = 0;
    std::vector<core::GapTerm> kept;
    for (std::size_t t = 0; t < g.terms.size(); ++t)
      if (use.terms[t]) kept.push_back(g.terms[t]);
    g.terms = std::move(kept);
    if (!g.empty()) cal.gap = std::move(g);
    per_fold[f] = compensate(rec, cal, rate);
  });
  HeldOut h;
  h.angle = a0;
  for (std::size_t f = 0; f < sx.blocks.size(); ++f) {
    const VectorXd& af = per_fold[f];
    const std::vector<cv::Span>& fold = sx.blocks.folds[f];
    for (const cv::Span& sp : fold) h.angle.segment(sp.start, sp.len) = af.segment(sp.start, sp.len);
    h.folds.push_back({{"rmse_before_deg", rms_of(a0, rec.angle_ref_deg, fold)}, {"rmse_after_deg", rms_of(af, rec.angle_ref_deg, fold)}});
  }
  // Every figure averages the squared error over the scans with an angle (the compensator gives
  // none while the reference fibre's light is lost), the baseline's too.
  score_blocks(h, h.angle, rec.angle_ref_deg, sx.blocks);
  h.rmse_deg = h.rmse_without_block(sx.blocks.size());
  return h;
}

}  // namespace

std::vector<bool> transition_scans(const Kinematics& k, double dt, double window_s) {
  const auto n = static_cast<std::size_t>(k.s_move.size());
  std::vector<bool> out(n, false);
  const auto len = static_cast<std::size_t>(std::lround(window_s / dt));
  for (std::size_t i = 1; i < n; ++i)
    if (k.s_move(static_cast<Index>(i)) != k.s_move(static_cast<Index>(i - 1)))
      for (std::size_t j = i; j < std::min(n, i + len); ++j) out[j] = true;
  return out;
}

core::Calibration calibration_of(const Structure& m, const Signals& s) {
  core::Calibration cal;
  cal.model = m.paper;
  if (m.dynamic) {
    cal.dynamic = m.dynamic;
    cal.active = core::ModelKind::kDynamic;
    // The angle as pof calibrate's file would have the compensator publish it: estimated from the
    // dynamic model with the recording's own noises (docs/calibration.md, "The angle estimator"),
    // inverted scan by scan only where they cannot be measured (no holds).
    try {
      cal.estimator = core::identify_estimator_noise(s.t, s.v, s.angle);
    } catch (const std::runtime_error&) {
      cal.estimator.reset();
    }
  }
  cal.reference_level_v = s.reference_level_v;
  cal.angle_min_deg = s.angle.minCoeff();
  cal.angle_max_deg = s.angle.maxCoeff();
  return cal;
}

OnlinePart online_part(const State& st, const CurrentFit& cur, const Context& cx, double rate_hz) {
  OnlinePart out;
  std::vector<bool> keep(st.terms.size(), true);
  for (const core::GapProblem& p : core::gap_problems(gap_model_of(st, cur.fit.beta_full, cx), rate_hz)) {
    if (p.term == 0 || !keep[p.term - 1]) continue;  // 1-based; a term named twice counts once
    keep[p.term - 1] = false;
    if (std::find(out.refused.begin(), out.refused.end(), p.effect) == out.refused.end()) out.refused.push_back(p.effect);
  }
  out.state = st;
  out.state.terms.clear();
  for (std::size_t t = 0; t < st.terms.size(); ++t)
    if (keep[t]) out.state.terms.push_back(st.terms[t]);
  return out;
}

namespace {

// One effect left out of the compensator's model: its name in the report, how to take it out of
// an Applied, and the held-out angle without it.
struct Without {
  std::string effect;
  void (*clear)(Applied&, std::size_t);
  std::size_t term;
  HeldOut h;
};

// The held-out angle with every effect of the state applied and with each left out in turn (the
// kinematics first, then the terms in order): what the choice of model.toml's effects reads.
struct EffectRuns {
  Applied all;
  HeldOut with_all;
  std::vector<Without> without;

  /// The effects kept when the choice may see the blocks other than `skip` (blocks.size(): all):
  /// one whose absence makes that angle better by > 2 % is left out.
  [[nodiscard]] Applied keep(std::size_t skip) const {
    Applied kept = all;
    const double with = with_all.rmse_without_block(skip);
    for (const Without& w : without)
      if (w.h.rmse_without_block(skip) < 0.98 * with) w.clear(kept, w.term);
    return kept;
  }

  /// The effects left out on every block, for the report ("left_out_of_model").
  [[nodiscard]] nlohmann::json left_out() const {
    nlohmann::json left_out = nlohmann::json::array();
    for (const Without& w : without)
      if (w.h.rmse_deg < 0.98 * with_all.rmse_deg)
        left_out.push_back({{"effect", w.effect}, {"rmse_with_deg", with_all.rmse_deg}, {"rmse_without_deg", w.h.rmse_deg}});
    return left_out;
  }
};

EffectRuns effect_runs(const CompensationInputs& in, const VectorXd& a0) {
  EffectRuns e;
  e.all.terms.assign(in.st.terms.size(), true);
  e.with_all = held_out(in.rec, in.sx, in.st, in.after, e.all, a0, in.threads);
  auto add_without = [&](std::string effect, void (*clear)(Applied&, std::size_t), std::size_t term) {
    Applied a = e.all;
    clear(a, term);
    e.without.push_back({std::move(effect), clear, term, held_out(in.rec, in.sx, in.st, in.after, a, a0, in.threads)});
  };
  if (in.st.delay_s != 0) add_without("time_delay", [](Applied& a, std::size_t) { a.delay = false; }, 0);
  if (in.st.backlash_deg > 0) add_without("backlash", [](Applied& a, std::size_t) { a.backlash = false; }, 0);
  for (std::size_t t = 0; t < in.st.terms.size(); ++t)
    add_without(std::string(core::to_string(in.st.terms[t].effect)), [](Applied& a, std::size_t i) { a.terms[i] = false; }, t);
  return e;
}

bool same(const Applied& a, const Applied& b) { return a.delay == b.delay && a.backlash == b.backlash && a.terms == b.terms; }

// The held-out angle of each set of kept effects, each set run once (the nested choice often
// keeps the same set for several blocks).
class KeptRuns {
 public:
  KeptRuns(const CompensationInputs& in, const EffectRuns& e, const VectorXd& a0) : in_(in), e_(e), a0_(a0) {}

  const HeldOut& of(const Applied& keep) {
    if (same(keep, e_.all)) return e_.with_all;
    for (const auto& [a, h] : runs_)
      if (same(a, keep)) return h;
    runs_.emplace_back(keep, held_out(in_.rec, in_.sx, in_.st, in_.after, keep, a0_, in_.threads));
    return runs_.back().second;
  }

 private:
  const CompensationInputs& in_;
  const EffectRuns& e_;
  const VectorXd& a0_;
  std::deque<std::pair<Applied, HeldOut>> runs_;  // a deque: the references handed out stay valid
};

// model.toml's held-out RMSE with its choice (the effects kept, or the baseline) made for each
// block from the other blocks alone and scored on that block.
double nested_rmse(const CompensationInputs& in, const EffectRuns& e, KeptRuns& runs, const HeldOut& base_blocks) {
  const bool found = !in.st.terms.empty() || in.st.delay_s != 0 || in.st.backlash_deg > 0;
  double ss_nested = 0;
  Index n_nested = 0;
  for (std::size_t f = 0; f < in.sx.blocks.size(); ++f) {
    // With nothing found, model.toml is the baseline; otherwise as analysis.cpp decides on all blocks.
    const HeldOut& h = runs.of(e.keep(f));
    const bool baseline_f = !found || !(h.rmse_without_block(f) < base_blocks.rmse_without_block(f));
    ss_nested += baseline_f ? base_blocks.ss[f] : h.ss[f];
    n_nested += baseline_f ? base_blocks.count[f] : h.count[f];
  }
  return n_nested > 0 ? std::sqrt(ss_nested / static_cast<double>(n_nested)) : std::numeric_limits<double>::quiet_NaN();
}

// The RMSEs before (a0) and after (a1) outside the transitions (see compensation.hpp); every
// scan belongs to one held-out block.
nlohmann::json steady_scores(const VectorXd& a0, const VectorXd& a1, const VectorXd& ref, const std::vector<bool>& transition) {
  double sb = 0, sa = 0, st_all = 0;
  Index ns = 0;
  for (Index i = 0; i < a0.size(); ++i) {
    const double eb = a0(i) - ref(i), ea = a1(i) - ref(i);
    if (!std::isfinite(eb) || !std::isfinite(ea)) continue;
    st_all += eb * eb;
    if (transition[static_cast<std::size_t>(i)]) continue;
    sb += eb * eb;
    sa += ea * ea;
    ++ns;
  }
  const double steady_before = ns > 0 ? std::sqrt(sb / static_cast<double>(ns)) : std::numeric_limits<double>::quiet_NaN();
  const double steady_after = ns > 0 ? std::sqrt(sa / static_cast<double>(ns)) : std::numeric_limits<double>::quiet_NaN();
  return {{"rmse_before_deg", steady_before},
          {"rmse_after_deg", steady_after},
          {"reduction_pct", steady_before > 0 ? 100.0 * (1.0 - steady_after / steady_before) : 0.0},
          {"share_of_scans", static_cast<double>(ns) / static_cast<double>(a0.size())},
          {"transition_share_of_squared_error_before", st_all > 0 ? 1.0 - sb / st_all : 0.0},
          {"how", "the scans more than 0.5 s (the compensator's velocity window) after every start, stop and reversal "
                  "of the reference"}};
}

}  // namespace

CompensatedScores compensated_rmse(const CompensationInputs& in) {
  const Signals& s = *in.sx.cx.s;
  const double rate = 1.0 / s.dt;
  const core::Calibration base = calibration_of(in.before, s);
  const VectorXd a0 = compensate(in.rec, base, rate);
  HeldOut base_blocks;
  score_blocks(base_blocks, a0, in.rec.angle_ref_deg, in.sx.blocks);
  const double before_deg = base_blocks.rmse_without_block(in.sx.blocks.size());  // every block

  // Each accepted effect left out in turn: one whose online application makes the held-out angle
  // worse (by > 2 %) is not written to model.toml (it stays named in the report), and if what is
  // kept is not better than the baseline, model.toml holds the baseline. Made on every block, the
  // choice has seen the blocks it is scored on, so rmse_written_deg is optimistic; the nested
  // figure makes the same choice for each block from the other blocks alone and scores it on that
  // block, which removes that choice's optimism (not the search's: its effects were accepted on
  // every block, and the baseline the choice may fall back to is fitted on every block).
  // docs/gap.md, section 5, "What model.toml holds".
  const EffectRuns effects = effect_runs(in, a0);
  const HeldOut& with_all = effects.with_all;
  KeptRuns runs(in, effects, a0);
  CompensatedScores out;
  out.written = effects.keep(in.sx.blocks.size());
  const nlohmann::json left_out = effects.left_out();
  const double written_deg = runs.of(out.written).rmse_deg;
  const double nested_deg = nested_rmse(in, effects, runs, base_blocks);
  const nlohmann::json steady = steady_scores(a0, with_all.angle, in.rec.angle_ref_deg, in.transition);
  out.angle_before = a0;
  out.angle_after = with_all.angle;
  out.report = {{"rmse_before_deg", before_deg},
                {"rmse_after_deg", with_all.rmse_deg},
                {"reduction_pct", before_deg > 0 ? 100.0 * (1.0 - with_all.rmse_deg / before_deg) : 0.0},
                {"folds", with_all.folds},
                {"not_applied", in.not_applied},
                {"left_out_of_model", left_out},
                {"rmse_written_deg", written_deg},
                {"model_toml_nested",
                 {{"rmse_deg", nested_deg},
                  {"reduction_pct", before_deg > 0 ? 100.0 * (1.0 - nested_deg / before_deg) : 0.0},
                  {"how", "for each held-out block, the effects model.toml would keep (and whether it would hold the "
                          "baseline) chosen on the other blocks alone, scored on that block: without the optimism of "
                          "rmse_written_deg's choice"}}},
                {"steady", steady},
                {"how", "core::OnlineCompensator over the recording (velocity from the sensor); before: the baseline "
                        "fitted to the recording; after: per fold, the model fitted on the other folds, scored on the "
                        "held-out block against angle_ref_deg"}};
  return out;
}

}  // namespace pof::gap
