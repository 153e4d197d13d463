// The gap workflow (docs/gap.md): the two baselines, a search from each and the choice between
// them, the compensated angle, and the improved model. The pieces live beside it: baseline.cpp
// (the structures fitted to the recording), steps.cpp (one search: the acceptance rule and
// iteration), search.cpp (the model and the candidates), cv.cpp (folds and least squares),
// compensation.cpp, whiteness.cpp, localise.cpp, ../effects/ (one file per effect).
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>
#include <string>

#include "baseline.hpp"
#include "compensation.hpp"
#include "pof/base/errors.hpp"
#include "pof/base/format.hpp"
#include "pof/core/compensator.hpp"
#include "pof/core/units.hpp"
#include "pof/gap/angle_gap.hpp"
#include "pof/gap/gap.hpp"
#include "pof/gap/localise.hpp"
#include "pof/io/report_json.hpp"
#include "search.hpp"
#include "steps.hpp"
#include "whiteness.hpp"

namespace pof::gap {

using Eigen::Index;
using Eigen::VectorXd;
using nlohmann::json;

namespace {

// Range and quasi-static quality of the recording, for the calibration-file layout.
void describe_range(json& model, const Signals& s, const Kinematics& k0) {
  double wmax = 0;
  Index n_holds = 0, run = 0;
  double sa = 0, sv = 0, saa = 0, svv = 0, sav = 0, nh = 0;
  for (Index i = 0; i < s.n; ++i) {
    wmax = std::max(wmax, std::abs(k0.w(i)));
    if (k0.s_move(i) == 0) {
      if (++run == static_cast<Index>(3.0 / s.dt)) ++n_holds;  // holds of >= 3 s
      const double a = s.angle(i), v = s.v(i);
      sa += a; sv += v; saa += a * a; svv += v * v; sav += a * v; nh += 1;
    } else {
      run = 0;
    }
  }
  const double cov = sav - sa * sv / nh, va = saa - sa * sa / nh, vv = svv - sv * sv / nh;
  model["range"] = {{"angle_min_deg", s.angle.minCoeff()}, {"angle_max_deg", s.angle.maxCoeff()},
                    {"velocity_min_rad_s", kHoldSpeedRadS}, {"velocity_max_rad_s", std::max(2 * kHoldSpeedRadS, wmax)}};
  model["linearity_r2"] = va > 0 && vv > 0 ? cov * cov / (va * vv) : 0.0;
  model["n_holds"] = n_holds;
}

// The dynamic baseline's bend lag named as the catalogue's `time_delay` (docs/gap.md, section 1,
// "What the baseline names"). The fibre's first-order lag behind the joint and a delay of the
// angle differ only at second order in the motion (-tau w + tau^2 a against -d w + d^2 a / 2), so
// at the recordings' speeds the dynamic fit can take a delay of the reference for a bend lag and
// fit it down to the noise (a measured case is in that section): the search then has nothing left
// to name, and the lateness, which a user wants to know (a DAQ's or a pipeline's delay, or the
// fibre's lag), would be reported nowhere.
// It is named when the lag passes the acceptance rule's first test on the fit's own cross-
// validation: its held-out error at least min_reduction below the best structure without a lag.
// Not when the search named a time_delay of its own (that one is reported, with its parameters).
std::optional<Step> named_bend_lag(const json& dyn, double baseline_gap_deg, const Options& opt,
                                   const std::vector<Step>& steps, bool dynamic_taken) {
  const double lag = dyn.value("bend_lag_s", 0.0);
  const double with = dyn.value("heldout_rmse_deg", 0.0), without = dyn.value("lag_free_heldout_rmse_deg", 0.0);
  if (!(lag > 0) || !(with > 0) || !(without > 0)) return std::nullopt;
  const double reduction = 1.0 - with / without;
  if (reduction < opt.min_reduction) return std::nullopt;
  if (std::any_of(steps.begin(), steps.end(), [](const Step& s) { return s.effect == core::to_string(core::Effect::kTimeDelay); }))
    return std::nullopt;
  Step s;
  s.effect = std::string(core::to_string(core::Effect::kTimeDelay));
  s.gap_deg = baseline_gap_deg;
  const std::string ms = format_fixed(1e3 * lag, 0);
  s.where = dynamic_taken ? "the sensor sees the angle late: the dynamic baseline carries it as the fibre's bend lag of " +
                                ms + " ms (a first-order lag and a delay look alike at these speeds)"
                          : "the sensor sees the angle late: the dynamic model's fit finds a bend lag of " + ms +
                                " ms; the paper structure taken here carries it in its velocity-dependent branches "
                                "(eqs. (11)/(12)), so no delay step is added";
  s.parameters = {{"delay_ms", 1e3 * lag}, {"bend_lag_s", lag}};
  s.evidence = {{"heldout_rmse_without_lag_deg", without},
                {"heldout_rmse_with_lag_deg", with},
                {"reduction_pct", 100 * reduction},
                {"how", "the dynamic model's own blocked cross-validation (core::fit_dynamic): its chosen structure "
                        "against the best one without a bend lag"}};
  return s;
}

// Whether the dynamic fit's lag is evidence of lateness on this recording. When the paper
// structure is taken, its velocity-dependent branches (eqs. (11)/(12)) carry a lateness (a delay d
// shifts the voltage by -d s'(theta) w, an offset growing with the speed) and the search from it
// finds no delay to add. The lag counts there only if the dynamic structure alone describes this
// sensor better than the paper structure alone, by min_reduction, and its search ends within that
// margin of the paper structure's (the two are one explanation told two ways): on a sensor of the
// paper's kind, or where the paper structure with its effects is clearly better, the lag is those
// branches seen by a model without them (docs/gap.md, section 1, "What the baseline names").
bool lag_is_evidence(const json& choice, bool dynamic_taken, const Options& opt) {
  if (dynamic_taken) return true;
  if (!choice.contains("dynamic")) return false;
  const double margin = 1.0 - opt.min_reduction;
  const auto gap = [&](const char* which, const char* key) { return choice.at(which).value(key, std::nan("")); };
  return gap("dynamic", "heldout_gap_deg") < margin * gap("paper", "heldout_gap_deg") &&
         gap("dynamic", "charged_gap_deg") * margin <= gap("paper", "charged_gap_deg");
}

// A first-order bend lag tau of the fibre and a delay d of the angle differ at second order in the
// motion: -tau w + tau^2 a against -d w + d^2 a / 2, so with d = tau by tau^2 a / 2 (docs/gap.md,
// section 1, "What the baseline names"). When that difference over this recording's accelerations
// stays within twice the scan-to-scan noise floor of the baseline's residual, the recording cannot
// say which it is (section 4, "Said, not hidden"); the compensator applies the structure's lag.
json lag_or_delay(double tau_s, const VectorXd& baseline_resid, const Steps& ctx) {
  const double floor = noise_floor(ctx.to_deg(baseline_resid));
  const auto n = static_cast<double>(ctx.k0->acc.size());
  const double second_order_rms = 0.5 * tau_s * tau_s * ctx.k0->acc.norm() / std::sqrt(n) * core::kDegPerRad;
  if (!(second_order_rms < 2 * floor)) return nullptr;
  return {{"effects", {"time_delay", "bend lag"}},
          {"what", "a delay of the angle (a DAQ's or a pipeline's latency) and the fibre's bend lag of " +
                       format_fixed(1e3 * tau_s, 0) + " ms: at this recording's accelerations they differ by " +
                       format_fixed(second_order_rms, 3) + " deg RMS, within twice the noise floor (" +
                       format_fixed(floor, 3) + " deg)"},
          {"second_order_rms_deg", second_order_rms},
          {"noise_floor_deg", floor},
          {"tells_apart",
           "fast moves with sharp starts and stops (a gait, steps at the drive's largest acceleration): a lag's "
           "error grows with the acceleration (tau^2 a against d^2 a / 2) and relaxes with tau after each stop, "
           "a delay's ends with the movement"},
          {"taken", "the dynamic model's bend lag (the compensator inverts it); reported as time_delay"}};
}

}  // namespace

json Result::to_json() const {
  json j;
  // A checkpoint's report says what it is whole up to (docs/gap.md, section 5, "Written as it goes").
  if (!complete()) j["stage"] = stage;
  j["baseline_gap_deg"] = baseline_gap_deg;
  auto steps_json = [](const std::vector<Step>& v) {
    json a = json::array();
    for (const Step& s : v)
      a.push_back({{"effect", s.effect}, {"gap_deg", s.gap_deg}, {"where", s.where}, {"parameters", s.parameters},
                   {"evidence", s.evidence}});
    return a;
  };
  j["in_baseline"] = steps_json(in_baseline);
  j["steps"] = steps_json(steps);
  j["final_gap_deg"] = final_gap_deg;
  j["unexplained"] = unexplained;
  j["indistinguishable"] = indistinguishable;
  j["baseline"] = baseline;
  j["whiteness"] = whiteness;
  j["model"] = model;
  j["recording"] = recording;
  j["compensated"] = compensated;
  j["angle_vs_forward"] = angle_vs_forward;
  return j;
}

namespace {

// `pof gap` reads the recording as the calibration protocol makes it: holds and movements both
// (the baseline's line and loop, and every effect's evidence).
void require_holds_and_movements(const io::Recording& rec, const Signals& s, const Kinematics& k0) {
  const std::string src = rec.source.empty() ? std::string("recording") : rec.source;
  const Index moving = (k0.s_move.array() != 0).count();
  if (moving < s.n / 20 || moving > s.n - s.n / 20)
    throw pof::DataError(src + ": `pof gap` needs both holds and movements (the calibration protocol); " +
                         std::to_string(moving) + " of " + std::to_string(s.n) + " scans move");
}

// Where the search from the paper structure starts: that structure as fitted here, the
// recording's range and speed (which bound the structure's moves) and the held-out blocks
// (docs/gap.md, section 4, "Folds").
Search paper_search(const Signals& s, const Kinematics& k0, const Baseline& base, const Options& opt) {
  Search sx0;
  sx0.cx.s = &s;
  sx0.cx.m = sx0.cx.origin = base.model;
  sx0.cx.angle_min_deg = s.angle.minCoeff();
  sx0.cx.angle_max_deg = s.angle.maxCoeff();
  sx0.cx.duration_s = s.t(s.n - 1) + s.dt;
  sx0.blocks = cv::make_blocks(k0, std::max(2, opt.folds), s.dt, opt.block_s);
  sx0.cx.max_speed_rad_s = k0.w.cwiseAbs().maxCoeff();
  sx0.cx.move_limit_deg = structure_move_limit(sx0.cx);
  return sx0;
}

// gap.json's "recording": its size and rate, and per fold its blocks as [first, last] scan times.
json recording_json(const Signals& s, const Search& sx0) {
  json recording = {{"scans", s.n}, {"rate_hz", 1.0 / s.dt}, {"duration_s", sx0.cx.duration_s},
                    {"reference_level_v", s.reference_level_v}, {"folds", sx0.blocks.size()}};
  json folds = json::array();
  for (const auto& fold : sx0.blocks.folds) {
    json spans = json::array();
    for (const cv::Span& sp : fold) spans.push_back({s.t(sp.start), s.t(sp.start + sp.len - 1)});
    folds.push_back(spans);
  }
  recording["fold_blocks_s"] = folds;
  return recording;
}

// The search kept and how it was chosen (gap.json's baseline.choice).
struct Chosen {
  Grown grown;
  json choice;
};

// Called with a search as it stands and what the analysis has reached (a checkpoint, below).
using Stage = std::function<void(const Grown&, const std::string&)>;

// A search's final held-out gap with every accepted effect charged the acceptance rule's margin:
// gap / (1 - min_reduction)^steps, the reduction an effect had to buy to be accepted.
double charged(const Grown& g, double margin) { return g.final_gap / std::pow(margin, static_cast<double>(g.steps.size())); }

// The second search, from the dynamic model: run when its structure alone beats the paper
// structure alone, or is not worse than the paper structure's charged final gap, by the margin
// either way (a dynamic structure missing one effect can lose to the paper structure with three,
// and win once it has that one); kept when charged less.
void consider_dynamic(Chosen& c, const Search& sx0, const Baseline& base, const Steps& ctx, double margin,
                      const Stage& stage) {
  const Options& opt = *ctx.opt;
  Grown& chosen = c.grown;
  json& choice = c.choice;
  Search sd = sx0;
  sd.cx.dyn = sd.cx.dyn_origin = base.dynamic;
  sd.cx.move_limit_deg = structure_move_limit(sd.cx);
  Grown dyn = baseline_alone(sd, ctx);
  choice["dynamic"] = {{"heldout_gap_deg", dyn.baseline_gap}};
  if (!(dyn.baseline_gap < margin * chosen.baseline_gap || dyn.baseline_gap * margin < charged(chosen, margin))) {
    choice["dynamic"]["not_searched"] = "its structure alone does not beat the paper structure alone, and is worse than the "
                                        "paper structure's charged final gap, by " + format_fixed(100 * opt.min_reduction, 0) + " %";
    return;
  }
  ctx.say("baseline: the dynamic model (held-out gap " + format_fixed(dyn.baseline_gap, 3) + " deg; the paper structure with its " +
          "effects " + format_fixed(chosen.final_gap, 3) + " deg): searching from it too");
  const std::string paper_said = "the paper structure's search done (" + format_fixed(chosen.final_gap, 3) +
                                 " deg in " + std::to_string(chosen.steps.size()) +
                                 " step(s)), the kept one not yet chosen";
  stage(chosen, "searching from the dynamic model (held-out gap " + format_fixed(dyn.baseline_gap, 3) +
                    " deg alone); " + paper_said);
  Steps dctx = ctx;
  dctx.accepted = [&](const Grown& g) {
    stage(g, "searching from the dynamic model, step " + std::to_string(g.steps.size()) + " accepted; " + paper_said);
  };
  grow(dyn, dctx);
  choice["dynamic"]["final_gap_deg"] = dyn.final_gap;
  choice["dynamic"]["steps"] = dyn.steps.size();
  choice["dynamic"]["charged_gap_deg"] = charged(dyn, margin);
  if (charged(dyn, margin) < charged(chosen, margin)) {
    choice["why"] = "the dynamic model with its effects has the lower held-out gap, each effect charged " +
                    format_fixed(100 * opt.min_reduction, 0) + " %";
    chosen = std::move(dyn);
  } else {
    choice["why"] = "the paper structure with its effects has the lower (or equal) held-out gap, each effect charged " +
                    format_fixed(100 * opt.min_reduction, 0) + " %";
  }
}

// The paper structure's search first; then the one from the second baseline, the dynamic model
// fitted to the recording (docs/gap.md, section 1, "Which baseline"). Two explanations are
// compared by their charged final gap: the same loop told by stop operators and Prony terms in the
// structure, or by memory and creep terms on the paper's steps, is one explanation, and the
// shorter one is preferred unless the longer is better by what its extra effects cost.
Chosen choose_search(const Search& sx0, const Baseline& base, const Steps& ctx, const Stage& stage) {
  const double margin = 1.0 - ctx.opt->min_reduction;
  ctx.say("baseline: the paper's structure");
  Chosen c{.grown = baseline_alone(sx0, ctx), .choice = json()};
  Grown& chosen = c.grown;
  ctx.say("baseline: held-out gap " + format_fixed(chosen.baseline_gap, 3) + " deg");
  stage(chosen, "the paper structure fitted, no effect searched yet");
  Steps pctx = ctx;
  pctx.accepted = [&](const Grown& g) {
    stage(g, "searching from the paper structure, step " + std::to_string(g.steps.size()) + " accepted");
  };
  grow(chosen, pctx);
  c.choice = {{"paper", {{"heldout_gap_deg", chosen.baseline_gap}, {"final_gap_deg", chosen.final_gap},
                         {"steps", chosen.steps.size()}, {"charged_gap_deg", charged(chosen, margin)}}}};
  if (base.dynamic) consider_dynamic(c, sx0, base, ctx, margin, stage);
  c.choice["chosen"] = chosen.sx.cx.dyn ? "dynamic" : "paper";
  return c;
}

// The chosen baseline in the report: its structure and held-out gap, the lag it names itself,
// and where its residual lies; the steps of its search.
void report_baseline(Result& res, const Baseline& base, const Grown& chosen, const json& choice, const Steps& ctx) {
  const Structure& baseline_model = chosen.baseline;
  res.baseline_gap_deg = chosen.baseline_gap;
  res.steps = chosen.steps;
  const bool dynamic_taken = chosen.sx.cx.dyn.has_value();
  if (base.dynamic && lag_is_evidence(choice, dynamic_taken, *ctx.opt)) {
    if (std::optional<Step> lag = named_bend_lag(base.detail["dynamic"], chosen.baseline_gap, *ctx.opt, res.steps,
                                                 dynamic_taken)) {
      if (json d = lag_or_delay(lag->parameters["bend_lag_s"].get<double>(), chosen.baseline_resid, ctx); !d.is_null())
        res.indistinguishable.push_back(std::move(d));
      res.in_baseline.push_back(std::move(*lag));
    }
  }
  for (const json& d : chosen.indistinguishable) res.indistinguishable.push_back(d);
  if (!chosen.last_rejected.is_null()) res.whiteness["last_rejected"] = chosen.last_rejected;
  const Localisation loc = localise(ctx.to_deg(chosen.baseline_resid), *ctx.s, *ctx.k0, *ctx.phases);
  res.baseline = base.detail;
  if (!choice.is_null()) res.baseline["choice"] = choice;
  res.baseline["structure"] = chosen.sx.cx.dyn ? "dynamic" : "paper";
  if (baseline_model.dynamic) res.baseline["dynamic"]["model"] = io::dynamic_model_json(*baseline_model.dynamic);
  res.baseline["c9_deg_per_v"] = base.model.c9;
  res.baseline["c10_deg"] = base.model.c10;
  res.baseline["heldout_gap_deg"] = res.baseline_gap_deg;
  res.baseline["where"] = loc.sentence;
  res.baseline["localisation"] = loc.detail;
}

// What the search left: its final gap, and how white its strict held-out residual rf [deg] is
// and where it lies.
void report_residual(Result& res, const Grown& chosen, const VectorXd& rf, const Steps& ctx) {
  res.final_gap_deg = chosen.final_gap;
  const Whiteness wh = whiteness(rf);
  for (auto it = wh.detail.begin(); it != wh.detail.end(); ++it) res.whiteness[it.key()] = it.value();
  res.unexplained = wh.unexplained;
  res.whiteness["final_where"] = localise(rf, *ctx.s, *ctx.k0, *ctx.phases).sentence;
}

// The loop closed: the model the compensator is given, which of its effects model.toml holds,
// and the compensator's angle with the baseline and with that model (docs/gap.md, section 5,
// "The loop closed").
struct LoopClosed {
  OnlinePart online;  // online.state: the part of the state the compensator applies
  AppliedFit applied;
  Applied written;
  VectorXd comp_before, comp_after;
};

// The model applied. With nothing to apply, the baseline as it is (not the structure moved on
// alone: that would score a refit, not a found effect).
// (A conditional between fit_state's result and `cur` would copy `cur`'s design matrix.)
AppliedFit applied_model(const Grown& chosen, const State& st_applied) {
  const Search& fin = chosen.sx;
  return st_applied.size() == 0                           ? applied_baseline(fin, chosen.baseline)
         : st_applied.terms.size() == chosen.st.terms.size() ? applied_fit(fin, st_applied, chosen.cur)
                                                             : applied_fit(fin, st_applied, fit_state(fin, st_applied));
}

// What the compensator refuses is neither applied nor written (model.toml must be a file
// pof-compensatord loads), and the model applied is fitted without it; it stays named in the
// report (compensated.not_applied). The scores go to res.compensated.
LoopClosed close_the_loop(Result& res, const io::Recording& rec, const Grown& chosen, const Steps& ctx) {
  const Signals& s = *ctx.s;
  LoopClosed lc;
  lc.online = online_part(chosen.st, chosen.cur, chosen.sx.cx, 1.0 / s.dt);
  const State& st_applied = lc.online.state;
  lc.applied = applied_model(chosen, st_applied);
  ctx.say("compensating the held-out blocks with the baseline and with the found model");
  try {
    const std::vector<bool> transition = transition_scans(*ctx.k0, s.dt, core::CompensatorSettings{}.velocity_window_s);
    CompensatedScores scores = compensated_rmse({.rec = rec,
                                                 .sx = chosen.sx,
                                                 .before = chosen.baseline,
                                                 .st = st_applied,
                                                 .after = lc.applied,
                                                 .not_applied = lc.online.refused,
                                                 .transition = transition,
                                                 .threads = ctx.opt->threads});
    res.compensated = std::move(scores.report);
    lc.written = std::move(scores.written);
    lc.comp_before = std::move(scores.angle_before);
    lc.comp_after = std::move(scores.angle_after);
  } catch (const std::exception& e) {
    // The compensator refused a model (std::invalid_argument from its constructor): the analysis
    // stands, model.toml holds the baseline, and the report says why.
    res.compensated = {{"error", std::string("the compensator could not run the found model: ") + e.what()}};
    lc.written.terms.assign(st_applied.terms.size(), false);
    lc.comp_before = lc.comp_after = VectorXd::Constant(s.n, std::numeric_limits<double>::quiet_NaN());
  }
  return lc;
}

// Whether model.toml holds the baseline: if even the effects kept make the compensator's held-out
// angle worse than the baseline does (a file that degrades the controller's angle helps no one;
// the effects stay named in gap.json and the report). Said in compensated.model_toml; the
// baseline's figure becomes rmse_written_deg and nothing is written.
bool choose_baseline_file(Result& res, LoopClosed& lc) {
  const bool write_baseline =
      !res.steps.empty() && (res.compensated.contains("error") || !(res.compensated["rmse_written_deg"].get<double>() <
                                                                    res.compensated["rmse_before_deg"].get<double>()));
  res.compensated["model_toml"] = !write_baseline                ? "found model"
                                  : lc.online.state.size() == 0 ? "baseline (the compensator can apply none of the effects found)"
                                                                : "baseline (the found model made the held-out angle worse)";
  if (write_baseline) {
    // rmse_written_deg is what model.toml holds: the baseline's now (the kept terms' was not lower).
    res.compensated["rmse_written_deg"] = res.compensated["rmse_before_deg"];
    lc.written.delay = lc.written.backlash = false;
    lc.written.terms.assign(lc.written.terms.size(), false);
  }
  return write_baseline;
}

// The terms model.toml holds: those written, with the coefficients fitted on all the data.
json written_terms(const LoopClosed& lc) {
  const core::GapModel g = gap_model_of(lc.online.state, lc.applied.beta_full, lc.applied.cx);
  json terms = json::array();
  for (std::size_t i = 0; i < g.terms.size(); ++i) {
    if (!lc.written.terms[i]) continue;  // its online application made the held-out angle worse
    const core::GapTerm& t = g.terms[i];
    json term = {{"effect", t.effect}, {"theta", t.theta}, {"coefficients_v", t.coefficients_v}};
    if (!t.thresholds_deg.empty()) term["thresholds_deg"] = t.thresholds_deg;
    if (!t.relay_centres_deg.empty()) term["relay_centres_deg"] = t.relay_centres_deg;
    if (!t.time_constants_s.empty()) term["time_constants_s"] = t.time_constants_s;
    json p = json::object();
    for (const auto& [k, v] : t.parameters) p[k] = v;
    term["parameters"] = p;
    terms.push_back(term);
  }
  return terms;
}

// The improved model, fitted on all the data (what model.toml holds): the structure (the baseline
// when write_baseline), the kinematics and terms written, and the recording's range.
void describe_model(Result& res, const LoopClosed& lc, const Grown& chosen, bool write_baseline, const Steps& ctx) {
  const Signals& s = *ctx.s;
  const State& st_applied = lc.online.state;
  const Structure mm = write_baseline ? chosen.baseline : lc.applied.structure();
  const json terms = written_terms(lc);
  res.model = coefficients_json(mm.paper);
  res.model["structure"] = mm.dynamic ? "dynamic" : "paper";
  if (mm.dynamic) res.model["dynamic"] = io::dynamic_model_json(*mm.dynamic);
  res.dynamic_model = mm.dynamic;
  res.model.update({{"reference_level_v", s.reference_level_v}, {"delay_s", lc.written.delay ? st_applied.delay_s : 0.0},
                    {"backlash_deg", lc.written.backlash ? st_applied.backlash_deg : 0.0}, {"duration_s", chosen.sx.cx.duration_s},
                    {"terms", terms}, {"left_out", res.compensated.value("left_out_of_model", json::array())}});
  describe_range(res.model, s, *ctx.k0);
}

// The found model's compensated angle beside the forward gap, and where a difference comes from
// (docs/gap.md, section 5, "Angle against the forward gap"). The input's noise in degrees is the
// held-out voltage residual over the local quasi-static slope of the structure applied: f5's
// 1/c9 on the paper structure, q'(angle) on the dynamic model, where a flat stretch of the curve
// makes any inverse noisy and is the sensor's doing, not the compensator's.
json angle_vs_forward(const Result& res, const io::Recording& rec, const Grown& chosen, const VectorXd& rf,
                      const LoopClosed& lc, const Steps& ctx) {
  if (res.compensated.contains("error")) return {{"error", res.compensated["error"]}};
  const Signals& s = *ctx.s;
  const Structure m = lc.applied.structure();
  VectorXd input_noise(s.n);
  for (Index i = 0; i < s.n; ++i) {
    const double slope = m.dynamic ? std::abs(m.dynamic->quasi_static_slope(s.angle(i))) : 1.0 / std::abs(m.paper.c9);
    input_noise(i) = chosen.strict_resid(i) / slope;
  }
  return compare_angle({.angle_deg = lc.comp_after,
                        .reference_deg = rec.angle_ref_deg,
                        .smooth_reference_deg = s.angle,
                        .forward_deg = rf,
                        .input_noise_deg = input_noise,
                        .k = *ctx.k0,
                        .phases = *ctx.phases,
                        .forward_gap_deg = res.final_gap_deg})
      .report;
}

// The plotted series, every stride-th scan (at most ~40k rows); rf: the final residual [deg].
Series plot_series(const Grown& chosen, const VectorXd& rf, const LoopClosed* lc, const Steps& ctx) {
  const Signals& s = *ctx.s;
  const Kinematics& k0 = *ctx.k0;
  const VectorXd resid_baseline = ctx.to_deg(chosen.baseline_resid);
  const VectorXd model_baseline = s.v - chosen.baseline_resid;
  const Index stride = std::max<Index>(1, s.n / 40000);
  const VectorXd model_final = s.v - chosen.strict_resid;
  Series series;
  for (Index i = 0; i < s.n; i += stride) {
    series.t.push_back(s.t(i));
    series.angle.push_back(s.angle(i));
    series.w.push_back(k0.w(i));
    series.v.push_back(s.v(i));
    series.model_baseline.push_back(model_baseline(i));
    series.model_final.push_back(model_final(i));
    series.resid_baseline_deg.push_back(resid_baseline(i));
    series.resid_final_deg.push_back(rf(i));
    // Not yet compensated (a checkpoint): NaN, which the plots skip.
    series.angle_comp_before.push_back(lc ? lc->comp_before(i) : std::numeric_limits<double>::quiet_NaN());
    series.angle_comp_after.push_back(lc ? lc->comp_after(i) : std::numeric_limits<double>::quiet_NaN());
  }
  return series;
}

// The report as it stands while the analysis runs (docs/gap.md, section 5, "Written as it goes"):
// search g with its steps so far, its residual and where it lies. No compensated angle and no
// model: the compensator checks the found model only once the searches are done.
void checkpoint(const Result& head, const Baseline& base, const Grown& g, const std::string& stage, const Steps& ctx) {
  Result r;
  r.stage = stage;
  r.recording = head.recording;
  report_baseline(r, base, g, json(), ctx);
  const VectorXd rf = ctx.to_deg(g.strict_resid);
  report_residual(r, g, rf, ctx);
  r.series = plot_series(g, rf, nullptr, ctx);
  r.dynamic_model = g.baseline.dynamic;
  ctx.opt->checkpoint(r);
}

}  // namespace

// The workflow of docs/gap.md: the baselines fitted, a search from each and the choice between
// them (sections 1, 3-4), the compensated angle and the model written (section 5).
Result analyse(const io::Recording& rec, const Options& opt) {
  auto say = [&](const std::string& m) { if (opt.progress) opt.progress(m); };
  const Signals s = make_signals(rec);
  const Kinematics k0 = make_kinematics(s.angle, s.dt, 0.0);
  require_holds_and_movements(rec, s, k0);

  say("baseline: fitting the paper's model structure to the recording (calibration, then every coefficient)");
  const Baseline base = fit_baseline(rec, s, k0);
  const Search sx0 = paper_search(s, k0, base, opt);
  const std::vector<Phase> phases = classify_phases(k0, s.dt);
  const Steps ctx{.s = &s,
                  .k0 = &k0,
                  .phases = &phases,
                  .opt = &opt,
                  .c9 = std::abs(base.model.c9),  // gaps in degrees at the paper fit's sensitivity, for every step
                  .say = say,
                  .accepted = nullptr};

  Result res;
  res.recording = recording_json(s, sx0);
  const Stage stage = [&](const Grown& g, const std::string& what) {
    if (opt.checkpoint) checkpoint(res, base, g, what, ctx);
  };
  const Chosen chosen = choose_search(sx0, base, ctx, stage);
  report_baseline(res, base, chosen.grown, chosen.choice, ctx);
  const VectorXd rf = ctx.to_deg(chosen.grown.strict_resid);
  report_residual(res, chosen.grown, rf, ctx);
  if (opt.checkpoint) {
    Result searched = res;
    searched.stage = "the searches done and the baseline chosen, the compensated angle not yet checked";
    searched.series = plot_series(chosen.grown, rf, nullptr, ctx);
    searched.dynamic_model = chosen.grown.baseline.dynamic;
    opt.checkpoint(searched);
  }

  LoopClosed lc = close_the_loop(res, rec, chosen.grown, ctx);
  const bool write_baseline = choose_baseline_file(res, lc);
  describe_model(res, lc, chosen.grown, write_baseline, ctx);
  res.angle_vs_forward = angle_vs_forward(res, rec, chosen.grown, rf, lc, ctx);
  res.series = plot_series(chosen.grown, rf, &lc, ctx);
  say("done: held-out gap " + format_fixed(res.baseline_gap_deg, 3) + " -> " + format_fixed(res.final_gap_deg, 3) + " deg in " +
      std::to_string(res.steps.size()) + " step(s)");
  return res;
}

}  // namespace pof::gap
