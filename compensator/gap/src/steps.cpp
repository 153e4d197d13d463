// One search of `pof gap` from one baseline (see steps.hpp).
#include "steps.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

#include "pof/base/format.hpp"
#include "whiteness.hpp"

namespace pof::gap {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using nlohmann::json;

double Steps::gap_deg(double cv_rss) const { return std::sqrt(cv_rss / static_cast<double>(s->n)) * c9; }

VectorXd Steps::to_deg(const VectorXd& r) const { return -r * c9; }

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Delete-one-block jackknife standard error of each physical parameter (robust to the strong
// autocorrelation of 200 Hz residuals, unlike the textbook least-squares covariance).
void add_jackknife(json& p, const std::vector<json>& folds) {
  if (folds.size() < 2) return;
  json se;
  for (auto it = p.begin(); it != p.end(); ++it) {
    double mean = 0;
    for (const json& f : folds) mean += f[it.key()].get<double>();
    mean /= static_cast<double>(folds.size());
    double ss = 0;
    for (const json& f : folds) ss += std::pow(f[it.key()].get<double>() - mean, 2);
    const double kk = static_cast<double>(folds.size());
    se[it.key() + "_se"] = std::sqrt((kk - 1) / kk * ss);
  }
  for (auto it = se.begin(); it != se.end(); ++it) p[it.key()] = it.value();
}



// The physical parameters of a just-accepted effect with their jackknife standard errors. A grid
// parameter is known no better than its grid: its standard error is at least the spacing at the
// chosen value / sqrt(12) (a jackknife of identical grid picks says 0).
json accepted_parameters(const EffectDef& def, const CandidateResult& w, const std::vector<json>& folds, Index k0cols,
                         const Context& cx) {
  const double th_full = w.grid.empty() ? 0.0 : w.grid[w.fit.full_idx];
  const VectorXd bfull = w.fit.beta_full;
  json params = def.physical(th_full, bfull.tail(bfull.size() - k0cols), cx);
  add_jackknife(params, folds);
  if (!def.theta_key.empty() && w.grid.size() > 1) {
    const std::string name(def.theta_key);
    double spacing = kInf;
    for (std::size_t i = 0; i < w.grid.size(); ++i)
      if (i != w.fit.full_idx && std::abs(w.grid[i] - th_full) > 0) spacing = std::min(spacing, std::abs(w.grid[i] - th_full));
    const double floor_se = def.theta_scale * spacing / std::sqrt(12.0);
    if (std::isfinite(floor_se) && params.contains(name + "_se") && params[name + "_se"].get<double>() < floor_se)
      params[name + "_se"] = floor_se;
  }
  return params;
}

// A candidate that passes the rule, assessed: its strict held-out residual (fold by fold with the
// fold's own training fit), its physical parameters with jackknife standard errors, and whether
// its magnitude is told apart from zero.
struct Assessment {
  const CandidateResult* candidate = nullptr;
  VectorXd after;
  json parameters;
  bool significant = true;
  std::string significance;
  std::optional<double> fast_part_reduction;  // effects with fast_part_s: the held-out reduction of the fast part
};

// The smallest held-out reduction of the residual's fast part an effect with slow random columns
// must reach (EffectDef::fast_part_s). A coupling that is there acts at every time scale the
// source's power moves on, so it explains part of the fast residual too; a slow column that only
// correlates by chance with a slow leftover (a creep's or a relaxation's tail; Granger and Newbold
// 1974) explains about none of it. 1 % lies between the two on the blind recordings (docs/gap.md,
// section 4, "Slow random columns").
constexpr double kMinFastPartReduction = 0.01;

// The held-out reduction of the residual's part faster than span_s by columns C's part faster than
// span_s (both less their centred mean over span_s), over the search's folds.
double fast_part_reduction(const MatrixXd& C, const VectorXd& resid, double span_s, const Search& sx) {
  const auto half = std::max<Index>(1, static_cast<Index>(std::lround(span_s / 2 / sx.cx.s->dt)));
  MatrixXd Cf(C.rows(), C.cols());
  for (Index j = 0; j < C.cols(); ++j) Cf.col(j) = C.col(j) - moving_mean(C.col(j), half);
  const VectorXd rf = resid - moving_mean(resid, half);
  const double rss0 = rf.squaredNorm();
  if (!(rss0 > 0)) return 0;
  return 1.0 - std::sqrt(cv::cross_validate({cv::make_grams(Cf, rf, sx.blocks)}, 0).cv_rss / rss0);
}

Assessment assess(const Search& sx, const State& st, const CandidateResult& w, Index k0cols, const VectorXd& before) {
  const EffectDef& def = effect_def(w.effect);
  Assessment a;
  a.candidate = &w;
  a.after.resize(sx.cx.s->n);
  Search at = sx;  // the candidate was scored at its own linearisation of the baseline
  at.cx.m = w.base.paper;
  at.cx.dyn = w.base.dynamic;
  std::vector<json> fold_params;
  for (std::size_t f = 0; f < sx.blocks.size(); ++f) {
    const double th = w.grid.empty() ? 0.0 : w.grid[w.fit.theta_idx[f]];
    const Design d2 = build_design(at, st.with(w.effect, th));
    for (const cv::Span& sp : sx.blocks.folds[f])
      a.after.segment(sp.start, sp.len) = d2.y.segment(sp.start, sp.len) - d2.X.middleRows(sp.start, sp.len) * w.fit.beta[f];
    const VectorXd bf = w.fit.beta[f];
    fold_params.push_back(def.physical(th, bf.tail(bf.size() - k0cols), at.cx));
  }
  a.parameters = accepted_parameters(def, w, fold_params, k0cols, at.cx);
  const std::string key(def.magnitude_key);
  if (!key.empty() && a.parameters.contains(key) && a.parameters.contains(key + "_se")) {
    const double x = a.parameters[key].get<double>(), se = a.parameters[key + "_se"].get<double>();
    a.significant = std::abs(x) > 2.0 * se;
    a.significance = key + " = " + format_fixed(x, 4) + " +- " + format_fixed(se, 4) + (a.significant ? " (> 2 SE)" : ": within 2 SE of zero");
  }
  if (a.significant && def.inadmissible != nullptr) {
    const std::string why = def.inadmissible(a.parameters);
    if (!why.empty()) {
      a.significant = false;
      a.significance = why;
    }
  }
  if (a.significant && def.fast_part_s > 0) {
    // The candidate's own columns at its all-data theta, on the kinematics of the state it joins.
    const double th_full = w.grid.empty() ? 0.0 : w.grid[w.fit.full_idx];
    const MatrixXd C = def.columns(th_full, at.cx, baseline_kinematics(at.cx, st.delay_s, st.backlash_deg));
    const double red = fast_part_reduction(C, before, def.fast_part_s, sx);
    a.fast_part_reduction = red;
    const std::string said = "the residual's part faster than " + format_fixed(def.fast_part_s, 0) + " s: held-out reduction " +
                             format_fixed(100 * red, 2) + " %";
    if (red < kMinFastPartReduction) {
      a.significant = false;
      a.significance = said + ", below " + format_fixed(100 * kMinFastPartReduction, 0) + " % (a slow correlation alone, which chance gives)";
    } else {
      a.significance += (a.significance.empty() ? "" : "; ") + said;
    }
  }
  return a;
}

// The fit with the baseline's coefficients moved by the all-data solution and the design rebuilt
// there (Gauss-Newton on the structure): with a new effect in the model the structure's
// coefficients move, further than one linear step around the effect-free fit may reach.
CurrentFit relinearise(Search& sx, const State& st) {
  CurrentFit cur = fit_state(sx, st);
  for (int it = 0; it < 2; ++it) {
    const Search at = moved(sx, cur.fit.beta_full);
    CurrentFit next = fit_state(at, st);
    if (!(next.fit.full_rss < cur.fit.full_rss)) break;
    sx.cx.m = at.cx.m;
    sx.cx.dyn = at.cx.dyn;
    cur = std::move(next);
  }
  return cur;
}

// Progress, to whoever listens (Steps::say may be empty).
void say(const Steps& ctx, const std::string& m) {
  if (ctx.say) ctx.say(m);
}

// One step's candidates against the current fit: each one's scores for the report, and the
// ranking by held-out delta BIC (docs/gap.md, section 4, "Ranking and the acceptance rule").
struct Ranking {
  double n_eff = 0;  // effective sample size of the current held-out residual
  double rss0 = 0;   // the current fit's held-out residual sum of squares
  json scores = json::object();
  std::vector<std::pair<double, std::size_t>> order;  // (delta BIC, candidate), best first
};

Ranking rank(const std::vector<CandidateResult>& cands, const CurrentFit& cur, const Steps& ctx) {
  Ranking r;
  r.n_eff = cv::effective_n(cur.cv_resid);
  r.rss0 = cur.fit.cv_rss;
  const double n_eff = r.n_eff, rss0 = r.rss0;
  for (std::size_t i = 0; i < cands.size(); ++i) {
    const CandidateResult& c = cands[i];
    const std::string id(core::to_string(c.effect));
    if (!c.eligible) { r.scores[id] = {{"applicable", false}, {"note", c.note}}; continue; }
    const double red = 1.0 - std::sqrt(c.fit.cv_rss / rss0);
    const double dbic = n_eff * std::log(c.fit.cv_rss / rss0) + c.n_params * std::log(n_eff);
    r.scores[id] = {{"heldout_gap_deg", ctx.gap_deg(c.fit.cv_rss)}, {"reduction_pct", 100 * red}, {"delta_bic", dbic},
                    {"parameters", c.n_params}};
    if (std::isfinite(dbic)) r.order.emplace_back(dbic, i);  // (a residual of exactly 0 leaves nothing to rank)
  }
  std::sort(r.order.begin(), r.order.end());
  return r;
}

// The acceptance rule: held-out RMS down by min_reduction and held-out BIC by min_delta_bic.
bool passes(Ranking& r, const std::vector<CandidateResult>& cands, std::size_t i, const Options& opt) {
  const double red = 1.0 - std::sqrt(cands[i].fit.cv_rss / r.rss0);
  return red >= opt.min_reduction && -r.scores[std::string(core::to_string(cands[i].effect))]["delta_bic"].get<double>() > opt.min_delta_bic;
}

// Parsimony between nested effects: the general one must beat the simpler one it generalises
// by the acceptance rule, as a further step on top of it would have to. The candidate to assess
// in place of i.
std::size_t parsimonious(Ranking& r, const std::vector<CandidateResult>& cands, std::size_t i, const Options& opt) {
  const double n_eff = r.n_eff;
  const auto simpler = effect_def(cands[i].effect).generalises;
  if (!simpler) return i;
  const auto si = static_cast<std::size_t>(*simpler);
  if (!cands[si].eligible) return i;
  const double red_over = 1.0 - std::sqrt(cands[i].fit.cv_rss / cands[si].fit.cv_rss);
  const double dbic_over = n_eff * std::log(cands[i].fit.cv_rss / cands[si].fit.cv_rss) +
                           (cands[i].n_params - cands[si].n_params) * std::log(n_eff);
  if (red_over >= opt.min_reduction && -dbic_over > opt.min_delta_bic) return i;
  r.scores[std::string(core::to_string(cands[i].effect))]["not_preferred_to"] = std::string(core::to_string(*simpler));
  return si;
}

// Two candidates explain the same residual on this recording (docs/gap.md, section 4, "Said, not
// hidden") when both pass the rule and are significant, what each explains is mostly the same part
// of the residual (their explained parts correlate by more than kSameResidual), and their held-out
// squared errors differ by less than 2 standard errors of that difference over the time blocks
// (blocks are the units the folds hold out; a difference smaller than its spread over them is one
// this recording does not resolve). The data then do not say which mechanism it is.
constexpr double kSameResidual = 0.8;

// What tells such a pair apart, where the catalogue knows it (docs/gap.md, section 4, "Confusable
// pairs"); "" for a pair it does not know.
std::string tells_apart(core::Effect a, core::Effect b) {
  auto is = [&](core::Effect x, core::Effect y) { return (a == x && b == y) || (a == y && b == x); };
  using core::Effect;
  if (is(Effect::kBacklash, Effect::kMemoryHysteresis))
    return "holds approached from both sides at several speeds and over several excursions: a dead band in the "
           "reference stands still for its width at every reversal while the sensor moves, the same at every speed "
           "and excursion; a play-type hysteresis in the fibre moves with the reference, and its loop changes with "
           "the excursion (minor loops) and, in a polymer, with the speed";
  if (is(Effect::kTimeDelay, Effect::kAccelerationDependence) ||
      is(Effect::kTimeDelay, Effect::kRateDependentHysteresis))
    return "moves at several speeds with stops of several decelerations: a delay shifts every movement by the same "
           "time and follows every change of the velocity; the other term has a shape of its own in the speed or "
           "the acceleration";
  if (is(Effect::kDrift, Effect::kCreep) || is(Effect::kDrift, Effect::kViscoelasticRelaxation))
    return "long holds after movements both ways and a long hold with no movement at all: a relaxation returns "
           "after each movement towards a level set by the angle's history, a drift goes on through the holds "
           "regardless";
  return "";
}

// Whether the compensator can apply an effect online (docs/calibration.md, "[gap]"): a drift is a
// trend over the calibration recording and has no online form (core::gap_problems refuses it).
bool applies_online(core::Effect e) { return e != core::Effect::kDrift; }

// The candidates ranked after `a` that tie with it (see kSameResidual), each described.
json ties_with(const Assessment& a, Ranking& r, const std::vector<CandidateResult>& cands, const Grown& g,
               const std::vector<std::size_t>& tried, const Steps& ctx, std::vector<Assessment>& tied) {
  const Options& opt = *ctx.opt;
  const VectorXd& before = g.cur.cv_resid;
  const VectorXd ea = before - a.after;
  json out = json::array();
  for (const auto& [dbic, j] : r.order) {
    if (!passes(r, cands, j, opt)) break;
    if (cands[j].effect == a.candidate->effect || std::find(tried.begin(), tried.end(), j) != tried.end()) continue;
    if (effect_def(cands[j].effect).generalises == a.candidate->effect ||
        effect_def(a.candidate->effect).generalises == cands[j].effect)
      continue;  // nested pairs are decided by the parsimony rule (section 4, "Nested effects")
    // Explaining the same residual, b explains about as much of it: less than half of what a
    // explains is no tie whatever its spread (and is not assessed, which costs a design per fold).
    if (r.rss0 - cands[j].fit.cv_rss < 0.5 * (r.rss0 - a.candidate->fit.cv_rss)) continue;
    Assessment b = assess(g.sx, g.st, cands[j], g.cur.d.X.cols(), before);
    if (!b.significant) continue;
    const VectorXd eb = before - b.after;
    const double overlap = ea.dot(eb) / std::sqrt(ea.squaredNorm() * eb.squaredNorm());
    // Held-out squared error of b minus a, block by block, and the standard error of their sum.
    std::vector<double> d;
    for (const auto& fold : g.sx.blocks.folds)
      for (const cv::Span& sp : fold)
        d.push_back(b.after.segment(sp.start, sp.len).squaredNorm() - a.after.segment(sp.start, sp.len).squaredNorm());
    const auto nb = static_cast<double>(d.size());
    double mean = 0, ss = 0;
    for (double x : d) mean += x / nb;
    for (double x : d) ss += (x - mean) * (x - mean);
    const double diff = mean * nb, se = nb > 1 ? std::sqrt(nb / (nb - 1) * ss) : 0.0;
    if (!(overlap > kSameResidual) || !(std::abs(diff) < 2 * se)) continue;
    const std::string id(core::to_string(cands[j].effect));
    out.push_back({{"effect", id},
                   {"heldout_gap_deg", ctx.gap_deg(b.after.squaredNorm())},
                   {"explained_overlap", overlap},
                   {"heldout_sse_difference_v2", diff},
                   {"heldout_sse_difference_se_v2", se},
                   {"parameters", b.parameters},
                   {"tells_apart", tells_apart(a.candidate->effect, cands[j].effect)}});
    r.scores[id]["indistinguishable_from"] = std::string(core::to_string(a.candidate->effect));
    tied.push_back(std::move(b));
  }
  return out;
}

// The held-out squared error per fold of a residual [V].
std::vector<double> fold_sse(const VectorXd& r, const cv::Blocks& blocks) {
  std::vector<double> out;
  for (const auto& fold : blocks.folds) {
    double s = 0;
    for (const cv::Span& sp : fold) s += r.segment(sp.start, sp.len).squaredNorm();
    out.push_back(s);
  }
  return out;
}

// The held-out squared error over all folds (the sum of fold_sse's entries).
double total(const std::vector<double>& per_fold) {
  double s = 0;
  for (double x : per_fold) s += x;
  return s;
}

// Whether the sum of b - a over folds is within 2 of its standard errors (the folds' spread).
bool within_2se(const std::vector<double>& a, const std::vector<double>& b) {
  const auto nf = static_cast<double>(a.size());
  double mean = 0, ss = 0;
  for (std::size_t f = 0; f < a.size(); ++f) mean += (b[f] - a[f]) / nf;
  for (std::size_t f = 0; f < a.size(); ++f) ss += std::pow(b[f] - a[f] - mean, 2);
  const double se = nf > 1 ? std::sqrt(nf / (nf - 1) * ss) : 0.0;
  return std::abs(mean * nf) <= 2 * se;
}

// A dead band in the reference against a play in the fibre (docs/gap.md, section 4, "Said, not
// hidden"). Both keep an offset of the sign of the last movement through the holds; they differ
// only in how it switches at a reversal (the reference standing while the sensor moves, or the
// sensor while the reference moves), which a reversal from a hold at the protocol's speeds resolves
// little. Stop operators are a play in the fibre, the dynamic baseline's or (on the paper
// structure) an accepted memory_hysteresis term's, and are refitted beside every backlash width, so the widths whose held-out error is within 2 SE of the best's (and
// "none" when the structure alone is too) are explanations the recording does not tell apart: how
// much of the loop is the belt's and how much the fibre's. Said when that range moves the hold offset
// (half the width) by more than twice the scan-to-scan noise floor: less is within the noise.
json dead_band_or_play(const std::vector<CandidateResult>& cands, const Grown& g, const Steps& ctx) {
  const auto& dyn = g.sx.cx.dyn;
  const bool structure_play = dyn && dyn->n_operators > 0;
  if (!structure_play && !g.st.has(core::Effect::kMemoryHysteresis)) return nullptr;
  const auto it = std::find_if(cands.begin(), cands.end(),
                               [](const CandidateResult& x) { return x.effect == core::Effect::kBacklash; });
  if (it == cands.end() || !it->eligible || it->profile.empty()) return nullptr;
  const CandidateResult& c = *it;
  std::size_t best = 0;
  for (std::size_t t = 1; t < c.profile.size(); ++t)
    if (total(c.profile[t]) < total(c.profile[best])) best = t;
  const std::vector<double> none = fold_sse(g.cur.cv_resid, g.sx.blocks);
  const bool none_alike = total(none) <= total(c.profile[best]) || within_2se(c.profile[best], none);
  double lo = none_alike ? 0.0 : c.profile_grid[best], hi = c.profile_grid[best];
  for (std::size_t t = 0; t < c.profile.size(); ++t)
    if (within_2se(c.profile[best], c.profile[t])) {
      lo = std::min(lo, c.profile_grid[t]);
      hi = std::max(hi, c.profile_grid[t]);
    }
  const double floor = noise_floor(ctx.to_deg(g.cur.cv_resid));
  if (!((hi - lo) / 2 > 2 * floor)) return nullptr;
  const bool at_edge = hi >= *std::max_element(c.profile_grid.begin(), c.profile_grid.end());
  return {{"effects", {"backlash", "memory_hysteresis"}},
          {"what", "a dead band of " + format_fixed(lo, 2) + " to " + (at_edge ? "at least " : "") +
                       format_fixed(hi, 2) + " deg" + (at_edge ? " (the widest tried)" : "") +
                       " between the joint and the reference, the rest of the loop a play-type hysteresis in the "
                       "fibre (" +
                       (structure_play ? "the dynamic baseline's " + std::to_string(dyn->n_operators) + " stop operators"
                                       : std::string("the memory_hysteresis term's stop operators")) +
                       ", refitted beside each width): the recording does not tell how the loop splits"},
          {"backlash_width_range_deg", {lo, hi}},
          {"best_width_deg", c.profile_grid[best]},
          {"none_alike", none_alike},
          {"noise_floor_deg", floor},
          {"tells_apart", tells_apart(core::Effect::kBacklash, core::Effect::kMemoryHysteresis)},
          {"taken", "as fitted: the compensator applies both the stop operators and a [gap] backlash_deg"}};
}

// The dynamic baseline's rate gain against the catalogue's rate-dependent hysteresis (docs/gap.md,
// section 4, "Said, not hidden"). The gain scales the stop operators' loop by phi(w), 1 at rest: a
// loop opening that changes with speed and is gone in holds, which is that effect's meaning, so a
// hidden one is taken up by the gain and the search, scoring the effect beside it, has nothing left
// to name. Where the gain is evidence (the structure without it is worse by min_reduction) and the
// effect's own column at a gain of 0 explains the held-out residual as well (within 2 SE over the
// folds, or better, and significant), the recording cannot say whether the loop's change with speed
// is the fibre's loop scaled or an opening of its own shape: said. Where the gain is a shape the
// effect cannot draw (a loop that is no sum of stop operators), the effect alone falls short.
json rate_gain_or_hysteresis(const Grown& g, const Steps& ctx) {
  const auto& dyn = g.sx.cx.dyn;
  constexpr core::Effect kRate = core::Effect::kRateDependentHysteresis;
  if (!dyn || dyn->rate_gain_s_per_rad == 0 || dyn->n_operators == 0 || g.st.has(kRate)) return nullptr;
  Search at0 = g.sx;
  at0.cx.dyn->rate_gain_s_per_rad = 0;
  const CurrentFit cur0 = fit_state(at0, g.st, g.cur.d.k);
  const double with_gain = ctx.gap_deg(g.cur.fit.cv_rss), without = ctx.gap_deg(cur0.fit.cv_rss);
  if (!(with_gain <= (1.0 - ctx.opt->min_reduction) * without)) return nullptr;
  const CandidateResult c = evaluate(kRate, at0, g.st, cur0);
  if (!c.eligible || c.grid.empty()) return nullptr;
  const Assessment a = assess(at0, g.st, c, cur0.d.X.cols(), cur0.cv_resid);
  if (!a.significant) return nullptr;
  const std::vector<double> gain = fold_sse(g.cur.cv_resid, g.sx.blocks), effect = fold_sse(a.after, g.sx.blocks);
  const double sg = total(gain), se = total(effect);
  if (!(se <= sg || within_2se(gain, effect))) return nullptr;
  const double kappa = dyn->rate_gain_s_per_rad, fastest = dyn->rate_factor(dyn->speed_limit_rad_s);
  return {{"effects", {"rate_dependent_hysteresis", "rate gain"}},
          {"what", "the dynamic baseline's loop " + std::string(kappa > 0 ? "opens" : "closes") + " with speed (rate gain " +
                       format_fixed(kappa, 2) + " s/rad, " + format_fixed(fastest, 2) + " times its width at rest by " +
                       format_fixed(dyn->speed_limit_rad_s, 2) + " rad/s; " + format_fixed(without, 3) + " deg without it, " +
                       format_fixed(with_gain, 3) + "), and a rate-dependent hysteresis of its own shape in place of the "
                       "gain explains the same (" + format_fixed(ctx.gap_deg(se), 3) +
                       " deg, within 2 SE): the recording does not tell the fibre's loop scaled by speed from an "
                       "opening beside it"},
          {"heldout_gap_with_gain_deg", with_gain},
          {"heldout_gap_without_gain_deg", without},
          {"heldout_gap_effect_at_no_gain_deg", ctx.gap_deg(se)},
          {"parameters", a.parameters},
          {"tells_apart",
           "moves at several speeds over several excursions, small ones among them: a scaled loop narrows or "
           "widens in proportion to the loop, minor loops too; an opening of its own keeps its size whatever the "
           "excursion and saturates with speed"},
          {"taken", "the rate gain, in the dynamic model the compensator runs"}};
}

// A first loading's columns: the running maximum and minimum of the angle, scaled to the recording's
// range, and their squares. A memory whose elements switch once and stay (Preisach relays whose
// other switching angle the angle never reaches; a polymer's softening up to the largest strain so
// far, the Mullins effect) gives an output that is a function of the extremes reached so far.
MatrixXd first_loading_columns(const VectorXd& angle) {
  const double lo = angle.minCoeff(), span = std::max(angle.maxCoeff() - lo, 1e-9);
  MatrixXd C(angle.size(), 4);
  double run_lo = angle(0), run_hi = angle(0);
  for (Index i = 0; i < angle.size(); ++i) {
    run_lo = std::min(run_lo, angle(i));
    run_hi = std::max(run_hi, angle(i));
    const double a = (run_hi - lo) / span, b = (run_lo - lo) / span;
    C.row(i) << a, a * a, b, b * b;
  }
  return C;
}

// A drift against a first loading (docs/gap.md, section 4, "First loading or drift"). Until the
// fibre has first been bent through the recording's range its response may differ for reasons of
// its own, which changes the output once, early in the session, as a warming source does, and a
// time basis fits either. When the first loading's columns (beside the state, fitted as every
// candidate is) explain the held-out residual as well as the drift (within 2 SE over the folds) or
// better, the recording cannot say which it is: said, not named. A drift that goes on after the angle has
// been through its range is no first loading and stays named.
json first_loading_or_drift(const Assessment& a, const Grown& g, const Steps& ctx) {
  const cv::Grams grams =
      cv::extend_grams(g.cur.grams, g.cur.d.X, first_loading_columns(ctx.s->angle), g.cur.d.y, g.sx.blocks);
  const std::vector<double> loading = cv::heldout_profile({grams}, base_cols(g.sx.cx)).front();
  const std::vector<double> drift = fold_sse(a.after, g.sx.blocks);
  const double sl = total(loading), sd = total(drift);
  if (!(sl <= sd || within_2se(drift, loading))) return nullptr;
  return {{"effects", {"drift", "first loading"}},
          {"what", "a drift and a first loading (the output a function of the largest and smallest angle reached so "
                   "far) explain the same residual, the first loading's held-out error within 2 SE of the drift's or below it (" +
                       format_fixed(ctx.gap_deg(sd), 3) + " against " + format_fixed(ctx.gap_deg(sl), 3) +
                       " deg): a change of the output early in the session, while the angle was first going through its "
                       "range"},
          {"heldout_gap_drift_deg", ctx.gap_deg(sd)},
          {"heldout_gap_first_loading_deg", ctx.gap_deg(sl)},
          {"tells_apart",
           "a session that starts with the fibre bent through its full range a few times (preconditioned), then "
           "holds: a drift goes on through the holds and after, a first loading is over once the range has been "
           "visited"},
          {"taken", "neither: a drift has no online form, and a first loading is over before the compensator runs on "
                    "a preconditioned fibre"}};
}

// The first candidate, best delta BIC first, that passes the rule and whose magnitude its
// jackknife tells apart from zero (|x| > 2 SE: a 4 +- 3 ms delay is no finding). Those that pass
// but are not told apart are said and marked in the scores. Candidates that explain the same
// residual as well (ties_with) are named beside it in `ties`; of them the search takes one the
// compensator can apply, so that model.toml holds what the data allow (docs/gap.md, section 4,
// "Said, not hidden").
std::optional<Assessment> first_significant(Ranking& r, const std::vector<CandidateResult>& cands, const Grown& g, int step,
                                            const Steps& ctx, json& ties, json& said) {
  const Options& opt = *ctx.opt;
  std::vector<std::size_t> tried;
  for (const auto& [dbic, i0] : r.order) {
    if (!passes(r, cands, i0, opt)) break;
    const std::size_t i = parsimonious(r, cands, i0, opt);
    if (!passes(r, cands, i, opt) || std::find(tried.begin(), tried.end(), i) != tried.end()) continue;
    tried.push_back(i);
    Assessment a = assess(g.sx, g.st, cands[i], g.cur.d.X.cols(), g.cur.cv_resid);
    if (!a.significant) {
      r.scores[std::string(core::to_string(cands[i].effect))]["not_significant"] = a.significance;
      say(ctx, "step " + std::to_string(step) + ": " + std::string(core::to_string(cands[i].effect)) + " " +
                   a.significance);
      continue;
    }
    if (cands[i].effect == core::Effect::kDrift)
      if (json d = first_loading_or_drift(a, g, ctx); !d.is_null()) {
        r.scores["drift"]["or_first_loading"] = d["heldout_gap_first_loading_deg"];
        say(ctx, "step " + std::to_string(step) + ": drift and a first loading explain the same residual here: "
                 "said, not named");
        said.push_back(std::move(d));
        continue;
      }
    std::vector<Assessment> tied;
    ties = ties_with(a, r, cands, g, tried, ctx, tied);
    if (!applies_online(a.candidate->effect))
      for (std::size_t k = 0; k < tied.size(); ++k)
        if (applies_online(tied[k].candidate->effect)) {
          // The tie's other member is taken; the one ranked first becomes its tie.
          json first = {{"effect", std::string(core::to_string(a.candidate->effect))},
                        {"heldout_gap_deg", ctx.gap_deg(a.after.squaredNorm())},
                        {"explained_overlap", ties[k]["explained_overlap"]},
                        {"heldout_sse_difference_v2", -ties[k]["heldout_sse_difference_v2"].get<double>()},
                        {"heldout_sse_difference_se_v2", ties[k]["heldout_sse_difference_se_v2"]},
                        {"parameters", a.parameters},
                        {"tells_apart", ties[k]["tells_apart"]},
                        {"ranked_first", true}};
          ties.erase(k);
          ties.push_back(first);
          return std::move(tied[k]);
        }
    return a;
  }
  return std::nullopt;
}

// No candidate accepted: the search stops, and the best ranked is kept to say why.
void record_stop(Grown& g, const Ranking& r, const std::vector<CandidateResult>& cands, int step, const Steps& ctx) {
  if (r.order.empty()) return;
  const CandidateResult& b = cands[r.order.front().second];
  const double red = 1.0 - std::sqrt(b.fit.cv_rss / r.rss0);
  // A drift that passed but was said beside a first loading (first_loading_or_drift) is not named
  // for that reason, not for lack of significance.
  const std::string id(core::to_string(b.effect));
  const bool said = r.scores.contains(id) && r.scores[id].contains("or_first_loading");
  say(ctx, "step " + std::to_string(step) + ": best " + id + " (" + format_fixed(100 * red, 1) + " %, dBIC " +
               format_fixed(r.order.front().first, 1) + "): " +
               (said ? "said beside a first loading, not named" : "not significant") + ", stopping");
  g.last_rejected = {{"effect", id}, {"reduction_pct", 100 * red},
                     {"delta_bic", r.order.front().first}, {"all", r.scores}};
}

// The best ranked candidate other than the accepted effect, and its delta BIC ("" and 0: none).
std::pair<std::string, double> runner_up_of(const Ranking& r, const std::vector<CandidateResult>& cands, core::Effect accepted) {
  std::string runner_up;
  double runner_bic = 0;
  for (const auto& [dbic, i] : r.order)
    if (cands[i].effect != accepted) { runner_up = std::string(core::to_string(cands[i].effect)); runner_bic = dbic; break; }
  return {runner_up, runner_bic};
}

// The accepted effect as the report's step: its held-out gaps, where the part of the residual it
// explains lies, its parameters and the evidence against the runner-up.
Step accepted_step(const Ranking& r, const std::vector<CandidateResult>& cands, const Assessment& chosen, const CurrentFit& cur,
                   int step, const Steps& ctx) {
  const CandidateResult& w = *chosen.candidate;
  const EffectDef& def = effect_def(w.effect);
  const std::string wid(core::to_string(w.effect));
  const double rss0 = r.rss0;
  const double red = 1.0 - std::sqrt(w.fit.cv_rss / rss0);
  const double wbic = r.scores[wid]["delta_bic"].get<double>();
  say(ctx, "step " + std::to_string(step) + ": " + wid + " (held-out gap " + format_fixed(ctx.gap_deg(rss0), 3) + " -> " +
               format_fixed(ctx.gap_deg(w.fit.cv_rss), 3) + " deg, " + format_fixed(100 * red, 1) + " %, dBIC " +
               format_fixed(wbic, 1) + "): accepted");

  // Where: the part of the residual this effect explains, localised.
  const VectorXd explained = ctx.to_deg(VectorXd(cur.cv_resid - chosen.after));
  const Localisation loc = localise(explained, *ctx.s, *ctx.k0, *ctx.phases);
  const Localisation before_loc = localise(ctx.to_deg(cur.cv_resid), *ctx.s, *ctx.k0, *ctx.phases);
  Step stp;
  stp.effect = wid;
  stp.gap_deg = ctx.gap_deg(w.fit.cv_rss);
  stp.where = loc.sentence;
  stp.parameters = chosen.parameters;
  const auto [runner_up, runner_bic] = runner_up_of(r, cands, w.effect);
  stp.evidence = {{"heldout_gap_before_deg", ctx.gap_deg(rss0)},
                  {"heldout_gap_after_deg", stp.gap_deg},
                  {"reduction_pct", 100 * red},
                  {"delta_bic", wbic},
                  {"n_eff", r.n_eff},
                  {"meaning", std::string(def.meaning)},
                  {"significance", chosen.significance},
                  {"runner_up", runner_up},
                  {"runner_up_delta_bic", runner_bic},
                  {"residual_before_where", before_loc.sentence},
                  {"phase_rms_before_deg", phase_rms(ctx.to_deg(cur.cv_resid), *ctx.phases)},
                  {"phase_rms_after_deg", phase_rms(ctx.to_deg(chosen.after), *ctx.phases)},
                  {"explained_localisation", loc.detail},
                  {"candidates", r.scores}};
  if (chosen.fast_part_reduction) stp.evidence["fast_part_heldout_reduction_pct"] = 100 * *chosen.fast_part_reduction;
  return stp;
}

// One relaxation spectrum, named once: a term of the simpler effect beside the one that
// generalises it (creep beside viscoelastic_relaxation, in either order) is one more time
// constant of the general one, and the step that added it is named so ("term" keeps what it
// added). Two names would claim two mechanisms where the catalogue tells them apart only by
// the number of time constants (docs/gap.md, section 4, "Nested effects").
void name_spectrum_once(Step& stp, std::vector<Step>& steps, const State& st, core::Effect added) {
  const EffectDef& def = effect_def(added);
  const std::string wid(core::to_string(added));
  for (const Term& t : st.terms)
    if (effect_def(t.effect).generalises == added) {
      stp.evidence["term"] = wid;
      stp.effect = std::string(core::to_string(t.effect));
    }
  if (def.generalises && st.has(*def.generalises))
    for (Step& earlier : steps)
      if (earlier.effect == core::to_string(*def.generalises)) {
        earlier.evidence["term"] = earlier.effect;
        earlier.effect = wid;
      }
}

// The accepted effect joins the state at its all-data theta and the candidate's baseline; the
// rate gain (dynamic baseline) and the terms' thetas are re-chosen beside it and the state
// relinearised for the next ranking (docs/gap.md, section 4, "Add and refit").
void adopt(Grown& g, const Assessment& chosen, const Steps& ctx) {
  const CandidateResult& w = *chosen.candidate;
  Search& sx = g.sx;
  State& st = g.st;
  const double th_full = w.grid.empty() ? 0.0 : w.grid[w.fit.full_idx];
  st = st.with(w.effect, th_full);
  sx.cx.m = w.base.paper;
  sx.cx.dyn = w.base.dynamic;
  bool gain_moved = false;
  if (sx.cx.dyn) {
    const double before = sx.cx.dyn->rate_gain_s_per_rad;
    refit_rate_gain(sx, st, ctx.opt->threads);
    gain_moved = sx.cx.dyn->rate_gain_s_per_rad != before;
    g.steps.back().evidence["dynamic_rate_gain_s_per_rad"] = {{"before", before}, {"after", sx.cx.dyn->rate_gain_s_per_rad}};
  }
  // A term's theta was chosen beside the others and the rate gain as they stood: re-chosen when
  // either has changed.
  if (st.size() > 1 || gain_moved) refit_thetas(sx, st, chosen.after, ctx.opt->threads);
  // The next ranking compares candidates with the state refitted the same way they are (accepted
  // nonlinear parameters fixed); the reported gaps stay the strict per-fold ones.
  g.cur = relinearise(sx, st);
  g.steps.back().evidence["heldout_gap_refitted_deg"] = ctx.gap_deg(g.cur.fit.cv_rss);
  g.strict_resid = chosen.after;
}

}  // namespace

Grown baseline_alone(Search from, const Steps& ctx) {
  Grown g;
  g.sx = std::move(from);
  // The structure is relinearised like every later state, so what the refit (every 4th scan,
  // <= 50 iterations) left is not credited to the first candidate.
  g.cur = relinearise(g.sx, g.st);
  g.baseline = moved_structure(g.sx.cx, g.cur.fit.beta_full);
  g.baseline_resid = g.strict_resid = g.cur.cv_resid;
  g.baseline_gap = g.final_gap = ctx.gap_deg(g.cur.fit.cv_rss);
  return g;
}

// Each step: every candidate fitted, ranked, the first significant one that passes the rule
// accepted and reported, and the state refitted with it (docs/gap.md, section 4).
void grow(Grown& g, const Steps& ctx) {
  for (int step = 1; step <= ctx.opt->max_steps; ++step) {
    say(ctx, "step " + std::to_string(step) + ": fitting " + std::to_string(core::kEffectCount) + " candidate effects");
    const std::vector<CandidateResult> cands = evaluate_all(g.sx, g.st, g.cur, ctx.opt->threads);
    Ranking r = rank(cands, g.cur, ctx);
    json ties = json::array(), said = json::array();
    const std::optional<Assessment> chosen = first_significant(r, cands, g, step, ctx, ties, said);
    for (json& d : said) {
      d["step"] = step;
      g.indistinguishable.push_back(std::move(d));
    }
    // The dead band's share is said where the search decides about it: the step that takes it, or
    // the one it stops at.
    const bool decides_backlash = !chosen || chosen->candidate->effect == core::Effect::kBacklash;
    if (decides_backlash && !g.st.has(core::Effect::kBacklash) && g.st.backlash_deg == 0)
      if (json d = dead_band_or_play(cands, g, ctx); !d.is_null()) {
        d["step"] = step;
        g.indistinguishable.push_back(std::move(d));
      }
    if (!chosen) {
      if (json d = rate_gain_or_hysteresis(g, ctx); !d.is_null()) {
        d["step"] = step;
        g.indistinguishable.push_back(std::move(d));
      }
      record_stop(g, r, cands, step, ctx);
      break;
    }
    Step stp = accepted_step(r, cands, *chosen, g.cur, step, ctx);
    if (!ties.empty()) {
      stp.evidence["indistinguishable_from"] = ties;
      for (const json& t : ties)
        g.indistinguishable.push_back({{"effects", {stp.effect, t["effect"]}},
                                       {"step", step},
                                       {"what", stp.effect + " and " + t["effect"].get<std::string>() +
                                                    " explain the same residual, their held-out errors within 2 SE"},
                                       {"tells_apart", t["tells_apart"]},
                                       {"taken", stp.effect}});
      for (const json& t : ties)
        say(ctx, "step " + std::to_string(step) + ": " + stp.effect + " and " + t["effect"].get<std::string>() +
                     " explain the same residual here: indistinguishable on this recording");
    }
    name_spectrum_once(stp, g.steps, g.st, chosen->candidate->effect);
    g.steps.push_back(std::move(stp));
    adopt(g, *chosen, ctx);
    g.final_gap = g.steps.back().gap_deg;
    if (ctx.accepted) ctx.accepted(g);
  }
  g.final_gap = g.steps.empty() ? g.baseline_gap : g.steps.back().gap_deg;
}

}  // namespace pof::gap
