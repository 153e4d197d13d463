// The model `pof gap` grows and the evaluation of candidates against it (see search.hpp).
#include "search.hpp"

#include "pof/core/dynamic_fit.hpp"
#include "pof/core/fit.hpp"
#include "pof/core/model.hpp"

#include <algorithm>
#include <array>

#include "parallel.hpp"

namespace pof::gap {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

bool State::has(core::Effect e) const {
  const Acts a = effect_def(e).acts;
  if (a == Acts::kDelay) return delay_s != 0;
  if (a == Acts::kBacklash) return backlash_deg > 0;
  return std::any_of(terms.begin(), terms.end(), [e](const Term& t) { return t.effect == e; });
}

State State::with(core::Effect e, double theta) const {
  State s = *this;
  switch (effect_def(e).acts) {
    case Acts::kDelay: s.delay_s = theta; break;
    case Acts::kBacklash: s.backlash_deg = theta; break;
    case Acts::kSensor: s.terms.push_back({e, theta}); break;
  }
  return s;
}

namespace {
// The stop operators the dynamic model as fitted to the recording (cx.dyn_origin) gives a weight.
std::vector<int> active_operators(const core::DynamicModel& fitted) {
  std::vector<int> out;
  for (int o = 0; o < fitted.n_operators; ++o)
    if (fitted.weight_v_per_deg[static_cast<std::size_t>(o)] != 0) out.push_back(o);
  return out;
}

// The dynamic structure's columns (base_cols) out of core::dynamic_regressors' (polynomial, stop
// operators, Prony) and a move of them applied to the full coefficient vector.
void write_dynamic_structure_columns(const core::DynamicModel& fitted, const MatrixXd& all, Eigen::Ref<MatrixXd> out) {
  const Index poly = fitted.degree + 1, ops = fitted.n_operators, prony = fitted.n_prony;
  const std::vector<int> active = active_operators(fitted);
  const auto na = static_cast<Index>(active.size());
  eigen_assert(out.rows() == all.rows() && out.cols() == poly + na + prony);
  out.leftCols(poly) = all.leftCols(poly);
  for (Index i = 0; i < na; ++i) out.col(poly + i) = all.col(poly + active[static_cast<std::size_t>(i)]);
  out.rightCols(prony) = all.middleCols(poly + ops, prony);
}

VectorXd dynamic_moved_by(const core::DynamicModel& fitted, VectorXd b, const VectorXd& step) {
  const Index poly = fitted.degree + 1, ops = fitted.n_operators, prony = fitted.n_prony;
  const std::vector<int> active = active_operators(fitted);
  const auto na = static_cast<Index>(active.size());
  b.head(poly) += step.head(poly);
  for (Index i = 0; i < na; ++i) {
    const auto o = static_cast<std::size_t>(active[static_cast<std::size_t>(i)]);
    double& w = b(poly + static_cast<Index>(o));
    const double moved = w + step(poly + i);
    w = moved * fitted.weight_v_per_deg[o] > 0 ? moved : 0.0;  // one sign: held at zero rather than across
  }
  b.segment(poly + ops, prony) += step.segment(poly + na, prony);
  return b;
}
}  // namespace

// On the dynamic baseline the structure's columns are the quasi-static polynomial's, the weights of
// the stop operators the fit uses and the Prony gains'. The weights share one sign
// (DynamicModel::invalid_reason; core::fit_dynamic fits them by sign-constrained least squares, and
// most land at zero): a free step over all of them gives every zero weight a value of either sign,
// no such step was ever invertible, and the structure did not move online while the held-out fit
// counted its move. An effect fitted beside that move then came on top of an operator that had
// already taken it (a stop operator of threshold b/2 at the line's slope is a belt play of width
// b, so a backlash found beside it is applied twice online; measured: docs/gap.md, section 1, "The
// dynamic structure in the design"). So, as in the fit's own active set, the weights the fit left
// at zero stay there and the others move, held at zero where a step would take one across (both
// as fitted to the recording: the design's columns are the same for every state of the search).
Index base_cols(const Context& cx) {
  if (!cx.dyn) return Index{core::kRefitParameters};
  return cx.dyn->degree + 1 + static_cast<Index>(active_operators(*cx.dyn_origin).size()) + cx.dyn->n_prony;
}

Kinematics baseline_kinematics(const Context& cx, double delay_s, double backlash_deg) {
  Kinematics k = make_kinematics(cx.s->angle, cx.s->dt, delay_s);
  if (backlash_deg > 0) apply_backlash(k, backlash_deg, cx.s->dt);
  return k;
}

Design build_design(const Search& sx, const State& st) {
  return build_design(sx, st, baseline_kinematics(sx.cx, st.delay_s, st.backlash_deg));
}

Design build_design(const Search& sx, const State& st, Kinematics k) {
  const Context& cx = sx.cx;
  Design d;
  d.k = std::move(k);
  const Index nb = base_cols(cx);
  std::vector<MatrixXd> cols;
  Index total = nb;
  for (const Term& t : st.terms) {
    cols.push_back(effect_def(t.effect).columns(t.theta, cx, d.k));
    total += cols.back().cols();
  }
  d.X.resize(cx.s->n, total);
  // The baseline simulator's voltage at these kinematics and, in the first columns, its gradient in
  // the structure's coefficients.
  if (cx.dyn) {
    // The dynamic model runs its memory over the angle the sensor sees (delayed, behind the play).
    const MatrixXd all = core::dynamic_regressors(*cx.dyn, d.k.angle, 1.0 / cx.s->dt);
    d.y = cx.s->v - all * core::dynamic_coefficients(*cx.dyn);
    write_dynamic_structure_columns(*cx.dyn_origin, all, d.X.leftCols(nb));
  } else {
    d.y = cx.s->v - paper_voltage(d.k, cx.m, d.X.leftCols(nb));
  }
  Index c = nb;
  for (const MatrixXd& C : cols) {
    d.X.middleCols(c, C.cols()) = C;
    c += C.cols();
  }
  return d;
}

VectorXd heldout_residual(const Design& d, const cv::Blocks& b, const std::vector<VectorXd>& beta) {
  VectorXd r(d.y.size());
  for (std::size_t i = 0; i < b.size(); ++i)
    for (const cv::Span& sp : b.folds[i])
      r.segment(sp.start, sp.len) = d.y.segment(sp.start, sp.len) - d.X.middleRows(sp.start, sp.len) * beta[i];
  return r;
}

CurrentFit fit_state(const Search& sx, const State& st) {
  return fit_state(sx, st, baseline_kinematics(sx.cx, st.delay_s, st.backlash_deg));
}

CurrentFit fit_state(const Search& sx, const State& st, Kinematics k) {
  CurrentFit c;
  c.d = build_design(sx, st, std::move(k));
  c.grams = cv::make_grams(c.d.X, c.d.y, sx.blocks);
  c.fit = cv::cross_validate({c.grams}, base_cols(sx.cx));
  c.cv_resid = heldout_residual(c.d, sx.blocks, c.fit.beta);
  return c;
}

namespace {

// The largest distance [deg] between two structures' moving branches, and of the first's from its
// own quasi-static line, over the recording's angle range and speeds up to `speed` (both
// directions, a 5 x 7 grid: the branches are smooth in both).
struct BranchDistance {
  double between = 0, own = 0;
};
BranchDistance branch_distance(const core::ModelCoefficients& a, const core::ModelCoefficients& b, const Context& cx,
                               double speed) {
  BranchDistance out;
  for (int i = 0; i <= 4; ++i) {
    const double angle = cx.angle_min_deg + (cx.angle_max_deg - cx.angle_min_deg) * i / 4.0;
    for (int j = 0; j <= 6; ++j) {
      const double w = speed * j / 6.0;
      for (const core::Direction d : {core::Direction::kFlexion, core::Direction::kExtension}) {
        const double va = core::model_voltage(a, angle, w, d);
        out.between = std::max(out.between, std::abs(va - core::model_voltage(b, angle, w, d)) * std::abs(a.c9));
        out.own = std::max(out.own, std::abs(va - core::quasi_static_voltage(a, angle)) * std::abs(a.c9));
      }
    }
  }
  return out;
}

core::ModelCoefficients moved_model(const Context& cx, const VectorXd& beta) {
  // The first-order step may be long along a direction the voltage barely tells apart (c3 against
  // c4 while c2 |w| is small, or the structure against a memory term that draws the same loop)
  // and land on a chain that is not invertible at some speed, or far from any sensor: it is
  // shortened (halved up to 8 times, then not taken) until
  //  - the chain is admissible up to 1.5x the recording's largest speed (the compensator's
  //    estimate overshoots the reference's), and
  //  - its moving branches are within the fitted baseline's own hysteresis (its largest branch
  //    offset from f5, at least kMinStructureMoveDeg) of the baseline's: a move may change the
  //    hysteresis by up to its size, not draw another sensor. An admissible chain still allows a
  //    move together with a term that draws the same loop (a memory term against eqs. (11)/(12)):
  //    the voltage fits offline while the branches lie far off f5, and the angle inverted online
  //    is far worse than the baseline's (docs/gap.md, section 1, "Every structure stays invertible").
  const std::array<double, core::kRefitParameters> p0 = core::refit_parameters(cx.m);
  const double speed = 1.5 * cx.max_speed_rad_s;
  const auto taken = core::halving_search([&](double scale) -> std::optional<core::ModelCoefficients> {
    std::array<double, core::kRefitParameters> p = p0;
    for (int i = 0; i < core::kRefitParameters; ++i) p[static_cast<std::size_t>(i)] += scale * beta(i);
    const core::ModelCoefficients m = core::with_refit_parameters(cx.m, p);
    if (core::chain_admissible(m, speed) && branch_distance(m, cx.origin, cx, speed).between <= cx.move_limit_deg) return m;
    return std::nullopt;
  });
  return taken.value_or(cx.m);
}

// The largest distance [deg] between two dynamic models' voltages over the recording's angle
// history, and of the first's from its own quasi-static curve (its hysteresis and relaxation),
// at the origin's sensitivity.
BranchDistance dynamic_distance(const core::DynamicModel& a, const core::DynamicModel& b, const Context& cx) {
  const double rate = 1.0 / cx.s->dt;
  const VectorXd va = core::forward_dynamic(a, cx.s->angle, rate), vb = core::forward_dynamic(b, cx.s->angle, rate);
  BranchDistance out;
  for (Index i = 0; i < va.size(); ++i) {
    const double th = cx.s->angle(i);
    if (!std::isfinite(va(i)) || !std::isfinite(vb(i)) || !std::isfinite(th)) continue;
    const double slope = std::abs(a.quasi_static_slope(th));
    if (!(slope > 0)) continue;
    out.between = std::max(out.between, std::abs(va(i) - vb(i)) / slope);
    out.own = std::max(out.own, std::abs(va(i) - a.quasi_static_v(th)) / slope);
  }
  return out;
}

// The dynamic baseline moved by beta: exact (the model is linear in its coefficients; the operator
// weights stay, see base_cols) but held to the same bounds as the paper structure's move:
// invertible online for every state of its memory (core::dynamic_invertible), and its voltage over
// the recording within its own hysteresis and relaxation (at least kMinStructureMoveDeg) of the
// fitted model's. Terms that draw the same curves as its parts are no candidates on this baseline
// (covered_by_baseline): a step along the difference of two such columns moves nothing the voltage
// sees, and a shortened step leaves the term's share applied alone.
core::DynamicModel dynamic_moved_fully(const Context& cx, const VectorXd& beta) {
  return core::with_dynamic_coefficients(
      *cx.dyn, dynamic_moved_by(*cx.dyn_origin, core::dynamic_coefficients(*cx.dyn), beta.head(base_cols(cx))));
}
bool dynamic_move_allowed(const core::DynamicModel& m, const Context& cx) {
  return core::dynamic_invertible(m, 1.0 / cx.s->dt) && dynamic_distance(m, *cx.dyn_origin, cx).between <= cx.move_limit_deg;
}
core::DynamicModel moved_dynamic(const Context& cx, const VectorXd& beta) {
  auto taken = core::halving_search([&](double scale) -> std::optional<core::DynamicModel> {
    core::DynamicModel m = dynamic_moved_fully(cx, scale * beta);
    if (dynamic_move_allowed(m, cx)) return m;
    return std::nullopt;
  });
  return taken ? std::move(*taken) : *cx.dyn;
}

}  // namespace

double structure_move_limit(const Context& cx) {
  const double own = cx.dyn_origin ? dynamic_distance(*cx.dyn_origin, *cx.dyn_origin, cx).own
                                   : branch_distance(cx.origin, cx.origin, cx, 1.5 * cx.max_speed_rad_s).own;
  return std::max(kMinStructureMoveDeg, own);
}

Structure moved_structure(const Context& cx, const VectorXd& beta) {
  if (cx.dyn) return {cx.m, moved_dynamic(cx, beta)};
  return {moved_model(cx, beta), std::nullopt};
}

Search moved(const Search& sx, const VectorXd& beta) {
  Search out = sx;
  const Structure m = moved_structure(sx.cx, beta);
  out.cx.m = m.paper;
  out.cx.dyn = m.dynamic;
  return out;
}

std::string covered_by_baseline(core::Effect e, const Context& cx) {
  if (!cx.dyn) return {};
  const core::DynamicModel& d = *cx.dyn;
  switch (e) {
    // memory_hysteresis is not held: its stop operators are, and on this baseline the term is
    // offered in its relay form only (effects/memory_hysteresis.cpp).
    case core::Effect::kCreep:
    case core::Effect::kViscoelasticRelaxation:
      if (d.n_prony > 0) return "held by the dynamic baseline's " + std::to_string(d.n_prony) + " Prony terms";
      break;
    case core::Effect::kStaticNonlinearity:
      if (d.degree > 1) return "held by the dynamic baseline's degree-" + std::to_string(d.degree) + " polynomial";
      break;
    default: break;
  }
  return {};
}

namespace {

// def.refine around best, kept inside the coarse grid's range: a refinement fills in between grid
// values and never leaves the range the grid searches (creep's tau >= 1 s, a rate-dependent
// hysteresis's velocity scale >= 0.02 rad/s, above the velocity estimate's noise; docs/gap.md,
// section 3, with the measured case). Refined around a refined value, the velocity scale could
// walk below that floor, where the estimate's noise switches the term at every start and stop.
std::vector<double> refined_within(const EffectDef& def, double best, const std::vector<double>& grid, const Context& cx) {
  std::vector<double> out;
  if (def.refine == nullptr || grid.empty()) return out;
  const auto [lo, hi] = std::minmax_element(grid.begin(), grid.end());
  for (double x : def.refine(best, cx))
    if (x >= *lo && x <= *hi) out.push_back(x);
  return out;
}

// The fit of state st on all data (its full_rss and beta_full; the state's grid is one value).
cv::FoldFit all_data_fit(const Design& d, const Search& sx) {
  return cv::cross_validate({cv::make_grams(d.X, d.y, sx.blocks)}, base_cols(sx.cx));
}
cv::FoldFit all_data_fit(const Search& sx, const State& st) { return all_data_fit(build_design(sx, st), sx); }

// The kinematics a coordinate's values share: none (each value moves them: the delay), those
// before the belt play (the play's width), or all of them (a term's theta).
enum class Shares { kNothing, kUpToPlay, kAll };

// Coordinate search of one scalar of the state over candidate values, on all data: the values are
// scored on `threads` workers, then taken in order (the first of equal fits wins, as in one pass).
template <class Set>
void coordinate(const Search& sx, State& st, const std::vector<double>& values, double current, Set set, int threads,
                Shares shares) {
  const Kinematics pre = shares == Shares::kNothing ? Kinematics{}
                         : shares == Shares::kAll   ? baseline_kinematics(sx.cx, st.delay_s, st.backlash_deg)
                                                    : make_kinematics(sx.cx.s->angle, sx.cx.s->dt, st.delay_s);
  auto rss_of = [&](const State& s2) {
    if (shares == Shares::kNothing) return all_data_fit(sx, s2).full_rss;
    Kinematics k = pre;
    if (shares == Shares::kUpToPlay && s2.backlash_deg > 0) apply_backlash(k, s2.backlash_deg, sx.cx.s->dt);
    return all_data_fit(build_design(sx, s2, std::move(k)), sx).full_rss;
  };
  std::vector<double> rss(values.size());
  parallel_for(values.size(), threads, [&](std::size_t i) {
    if (values[i] == current) return;
    State s2 = st;
    set(s2, values[i]);
    rss[i] = rss_of(s2);
  });
  double best = rss_of(st), bv = current;
  for (std::size_t i = 0; i < values.size(); ++i)
    if (values[i] != current && rss[i] < best) { best = rss[i]; bv = values[i]; }
  set(st, bv);
}

}  // namespace

void refit_thetas(const Search& sx, State& st, const VectorXd& resid, int threads) {
  // A creep time constant fitted while a delay was still missing would otherwise stay biased.
  if (st.delay_s != 0) {
    std::vector<double> v;
    for (int j = -20; j <= 20; ++j) v.push_back(st.delay_s + j * 0.001);
    coordinate(sx, st, v, st.delay_s, [](State& s, double x) { s.delay_s = x; }, threads, Shares::kNothing);
  }
  if (st.backlash_deg > 0) {
    std::vector<double> v;
    for (int j = -10; j <= 10; ++j)
      if (st.backlash_deg + j * 0.02 > 0) v.push_back(st.backlash_deg + j * 0.02);
    coordinate(sx, st, v, st.backlash_deg, [](State& s, double x) { s.backlash_deg = x; }, threads, Shares::kUpToPlay);
  }
  for (std::size_t i = 0; i < st.terms.size(); ++i) {
    const EffectDef& def = effect_def(st.terms[i].effect);
    if (!def.refit_theta) continue;
    std::vector<double> values = def.grid(sx.cx, resid);
    const std::vector<double> fine = refined_within(def, st.terms[i].theta, values, sx.cx);
    values.insert(values.end(), fine.begin(), fine.end());
    coordinate(sx, st, values, st.terms[i].theta, [i](State& s, double x) { s.terms[i].theta = x; }, threads,
               Shares::kAll);
  }
}

void refit_rate_gain(Search& sx, const State& st, int threads) {
  // phi(w) multiplies the stop operators only: without one the gain changes nothing.
  if (!sx.cx.dyn || active_operators(*sx.cx.dyn_origin).empty()) return;
  // The all-data fit at gain g (the structure's coefficients free) and whether the structure can
  // make that move: invertible online and within the move bound, moved_dynamic's conditions
  // without its shortening of the step, so a gain is not scored by a move it will not make.
  struct Score {
    double rss = 0;
    bool feasible = false;
  };
  const Kinematics k = baseline_kinematics(sx.cx, st.delay_s, st.backlash_deg);  // the gains share them
  auto score = [&](double g) {
    Search at = sx;
    at.cx.dyn->rate_gain_s_per_rad = g;
    const cv::FoldFit f = all_data_fit(build_design(at, st, k), at);
    return Score{f.full_rss, dynamic_move_allowed(dynamic_moved_fully(at.cx, f.beta_full), at.cx)};
  };
  // The gain in place stays unless a feasible one fits better.
  const double current = sx.cx.dyn->rate_gain_s_per_rad;
  const std::vector<double> gains = core::DynamicFitSettings{}.rate_gains_s_per_rad;
  std::vector<Score> scores(gains.size());
  parallel_for(gains.size(), threads, [&](std::size_t i) {
    if (gains[i] != current) scores[i] = score(gains[i]);
  });
  double best = score(current).rss, best_gain = current;
  for (std::size_t i = 0; i < gains.size(); ++i)
    if (gains[i] != current && scores[i].feasible && scores[i].rss < best) { best = scores[i].rss; best_gain = gains[i]; }
  sx.cx.dyn->rate_gain_s_per_rad = best_gain;
}

CandidateResult evaluate(core::Effect e, const Search& sx, const State& st, const CurrentFit& cur) {
  const EffectDef& def = effect_def(e);
  CandidateResult cr;
  cr.effect = e;
  const bool has_theta = !def.theta_key.empty();
  cr.n_params = linear_columns(def, sx.cx) + (has_theta ? 1 : 0);
  // Interference may be found again at another frequency; every other effect enters once.
  if (st.has(e) && e != core::Effect::kPeriodicInterference) {
    cr.eligible = false;
    cr.note = "already in the model";
    return cr;
  }
  if (const std::string why = covered_by_baseline(e, sx.cx); !why.empty()) {
    cr.eligible = false;
    cr.note = why;
    return cr;
  }
  if (def.not_identifiable != nullptr) {
    const std::string_view why = def.not_identifiable(sx.cx);
    if (!why.empty()) {
      cr.eligible = false;
      cr.note = std::string(why);
      return cr;
    }
  }
  cr.grid = def.grid(sx.cx, cur.cv_resid);
  if (cr.grid.empty()) {  // a grid fitted to the recording with nothing in it (not_identifiable says why)
    cr.eligible = false;
    cr.note = "no value of its parameter fits this recording";
    return cr;
  }
  // Sensor candidates extend the current grams by their columns (by the effect's whole column set
  // once per fit, when it has one: EffectDef::column_set); kinematic ones rebuild the whole design
  // for each grid value.
  auto set_grams_of = [&](const Search& at, const CurrentFit& c) {
    return def.column_set != nullptr ? cv::extend_grams(c.grams, c.d.X, def.column_set(at.cx, c.d.k), c.d.y, at.blocks)
                                     : cv::Grams{};
  };
  std::optional<Kinematics> pre_play;
  auto grams_at = [&](const Search& at, const CurrentFit& c, const cv::Grams& set_grams, double th) {
    if (def.column_set != nullptr) return cv::select_columns(set_grams, c.d.X.cols(), def.columns_in_set(th));
    if (def.acts == Acts::kSensor)
      return cv::extend_grams(c.grams, c.d.X, def.columns(th, at.cx, c.d.k), c.d.y, at.blocks);
    if (def.acts == Acts::kDelay && th == 0.0) return c.grams;
    if (def.acts == Acts::kBacklash) {
      // Every width shares the kinematics before the play (the state's delay).
      if (!pre_play) pre_play = make_kinematics(sx.cx.s->angle, sx.cx.s->dt, st.delay_s);
      Kinematics k = *pre_play;
      apply_backlash(k, th, sx.cx.s->dt);
      const Design dd = build_design(at, st.with(e, th), std::move(k));
      return cv::make_grams(dd.X, dd.y, at.blocks);
    }
    const Design dd = build_design(at, st.with(e, th));
    return cv::make_grams(dd.X, dd.y, at.blocks);
  };
  std::vector<cv::Grams> per;
  const cv::Grams cur_set = set_grams_of(sx, cur);
  for (double th : cr.grid) per.push_back(grams_at(sx, cur, cur_set, th));
  const std::vector<double> coarse = cr.grid;
  if (def.refine != nullptr) {
    // Refine around the coarse optimum chosen on all data; per fold the grid value is still chosen
    // on the training blocks only, over the coarse and the fine values.
    const double c0 = cr.grid[cv::cross_validate(per, base_cols(sx.cx)).full_idx];
    for (double th : refined_within(def, c0, coarse, sx.cx)) {
      cr.grid.push_back(th);
      per.push_back(grams_at(sx, cur, cur_set, th));
    }
  }
  cr.fit = cv::cross_validate(per, base_cols(sx.cx));
  cr.base = {sx.cx.m, sx.cx.dyn};
  if (def.acts != Acts::kSensor) {
    cr.profile_grid = cr.grid;
    cr.profile = cv::heldout_profile(per, base_cols(sx.cx));
  }
  // Gauss-Newton on the structure: with the effect in the model the baseline's coefficients move
  // (a delay had been partly absorbed by the hysteresis coefficients), further than the
  // first-order columns reach. Rebuilt at the moved coefficients, the candidate is scored again,
  // up to three times while that lowers its score by > 1 %; only for candidates that already
  // explain something, over the best value and its refinement.
  if (cr.fit.cv_rss < 0.98 * cur.fit.cv_rss) {
    const double best = cr.grid[cr.fit.full_idx];
    std::vector<double> grid{best};
    if (def.refine != nullptr)
      for (double th : refined_within(def, best, coarse, sx.cx)) grid.push_back(th);
    else
      grid = cr.grid;
    Search at = sx;
    cv::FoldFit f = cr.fit;
    for (int it = 0; it < 3; ++it) {
      const Search next = moved(at, f.beta_full);
      const CurrentFit c2 = fit_state(next, st, cur.d.k);  // the state's kinematics: the structure moved
      const cv::Grams c2_set = set_grams_of(next, c2);
      std::vector<cv::Grams> per2;
      for (double th : grid) per2.push_back(grams_at(next, c2, c2_set, th));
      cv::FoldFit f2 = cv::cross_validate(per2, base_cols(next.cx));
      if (!(f2.cv_rss < 0.99 * f.cv_rss)) {
        if (f2.cv_rss < f.cv_rss) { f = std::move(f2); at = next; }
        break;
      }
      f = std::move(f2);
      at = next;
    }
    if (f.cv_rss < cr.fit.cv_rss) {
      cr.fit = std::move(f);
      cr.grid = grid;
      cr.base = {at.cx.m, at.cx.dyn};
    }
  }
  return cr;
}

std::vector<CandidateResult> evaluate_all(const Search& sx, const State& st, const CurrentFit& cur, int threads) {
  std::vector<CandidateResult> out(core::kEffectCount);
  parallel_for(out.size(), threads, [&](std::size_t i) { out[i] = evaluate(core::kAllEffects[i], sx, st, cur); });
  return out;
}

}  // namespace pof::gap
