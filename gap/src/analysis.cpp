// The gap workflow (docs/gap.md): baseline, candidate effects ranked by time-blocked
// cross-validation, the acceptance rule, iteration, and the improved model. The pieces live beside
// it: baseline.cpp (the structure fitted to the recording), search.cpp (the model and the
// candidates), cv.cpp (folds and least squares), whiteness.cpp, localise.cpp, ../effects/ (one
// file per effect).
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <string>

#include "baseline.hpp"
#include "compensation.hpp"
#include "pof/base/errors.hpp"
#include "pof/core/compensator.hpp"
#include "pof/gap/gap.hpp"
#include "pof/gap/localise.hpp"
#include "pof/io/report_json.hpp"
#include "search.hpp"
#include "whiteness.hpp"

namespace pof::gap {

using Eigen::Index;
using Eigen::VectorXd;
using nlohmann::json;

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

std::string fmt(double x, int prec = 3) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(prec);
  o << x;
  return o.str();
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
};

Assessment assess(const Search& sx, const State& st, const CandidateResult& w, Index k0cols) {
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
    const Index b = sx.blocks.start[f], l = sx.blocks.len[f];
    a.after.segment(b, l) = d2.y.segment(b, l) - d2.X.middleRows(b, l) * w.fit.beta[f];
    const VectorXd bf = w.fit.beta[f];
    fold_params.push_back(def.physical(th, bf.tail(bf.size() - k0cols), at.cx));
  }
  a.parameters = accepted_parameters(def, w, fold_params, k0cols, at.cx);
  const std::string key(def.magnitude_key);
  if (!key.empty() && a.parameters.contains(key) && a.parameters.contains(key + "_se")) {
    const double x = a.parameters[key].get<double>(), se = a.parameters[key + "_se"].get<double>();
    a.significant = std::abs(x) > 2.0 * se;
    a.significance = key + " = " + fmt(x, 4) + " +- " + fmt(se, 4) + (a.significant ? " (> 2 SE)" : ": within 2 SE of zero");
  }
  if (a.significant && def.inadmissible != nullptr) {
    const std::string why = def.inadmissible(a.parameters);
    if (!why.empty()) {
      a.significant = false;
      a.significance = why;
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

}  // namespace

json Result::to_json() const {
  json j;
  j["baseline_gap_deg"] = baseline_gap_deg;
  j["steps"] = json::array();
  for (const Step& s : steps)
    j["steps"].push_back({{"effect", s.effect}, {"gap_deg", s.gap_deg}, {"where", s.where},
                          {"parameters", s.parameters}, {"evidence", s.evidence}});
  j["final_gap_deg"] = final_gap_deg;
  j["unexplained"] = unexplained;
  j["baseline"] = baseline;
  j["whiteness"] = whiteness;
  j["model"] = model;
  j["recording"] = recording;
  j["compensated"] = compensated;
  return j;
}

Result analyse(const io::Recording& rec, const Options& opt) {
  auto say = [&](const std::string& m) { if (opt.progress) opt.progress(m); };
  const Signals s = make_signals(rec);
  const std::string src = rec.source.empty() ? std::string("recording") : rec.source;
  const Kinematics kp = make_kinematics(s.angle, s.dt, 0.0, core::paper_coefficients());
  const Index moving = (kp.s_move.array() != 0).count();
  if (moving < s.n / 20 || moving > s.n - s.n / 20)
    throw pof::DataError(src + ": `pof gap` needs both holds and movements (the calibration protocol); " +
                         std::to_string(moving) + " of " + std::to_string(s.n) + " scans move");

  say("baseline: fitting the paper's model structure to the recording (calibration, then every coefficient)");
  const Baseline base = fit_baseline(rec, s, kp);
  Search sx0;
  sx0.cx.s = &s;
  sx0.cx.m = sx0.cx.origin = base.model;
  sx0.cx.angle_min_deg = s.angle.minCoeff();
  sx0.cx.angle_max_deg = s.angle.maxCoeff();
  sx0.cx.duration_s = s.t(s.n - 1) + s.dt;
  sx0.blocks = cv::make_blocks(kp, std::max(2, opt.folds));
  const Kinematics k0 = make_kinematics(s.angle, s.dt, 0.0, base.model);
  sx0.cx.max_speed_rad_s = k0.w.cwiseAbs().maxCoeff();
  const std::vector<Phase> phases = classify_phases(k0, s.dt);
  const double N = static_cast<double>(s.n);
  const double c9 = std::abs(base.model.c9);  // gaps in degrees at the baseline's sensitivity, for every step
  auto gap_deg = [&](double cv_rss) { return std::sqrt(cv_rss / N) * c9; };
  // Residual in degrees: positive when the sensor reads a larger angle than the model (dv/dangle < 0).
  auto to_deg = [&](const VectorXd& r) { return VectorXd(-r * c9); };

  Result res;
  res.recording = {{"scans", s.n}, {"rate_hz", 1.0 / s.dt}, {"duration_s", sx0.cx.duration_s},
                   {"reference_level_v", s.reference_level_v}, {"folds", sx0.blocks.size()}};
  json bounds = json::array();
  for (std::size_t i = 0; i < sx0.blocks.size(); ++i) bounds.push_back(s.t(sx0.blocks.start[i]));
  res.recording["fold_start_s"] = bounds;

  // One search per baseline: `start` fits the structure alone, `grow` adds effects one step at a
  // time (docs/gap.md, sections 3-4).
  struct Grown {
    Search sx;
    State st;
    CurrentFit cur;
    Structure baseline;      // the structure alone, fitted on all data
    VectorXd baseline_resid;  // its held-out residual [V]
    double baseline_gap = 0, final_gap = 0;
    std::vector<Step> steps;
    VectorXd strict_resid;  // the held-out residual of the last accepted step [V]
    json last_rejected;
  };
  auto start = [&](Search from) {
    Grown g;
    g.sx = std::move(from);
    // The structure is relinearised like every later state, so what the refit (every 4th scan,
    // <= 50 iterations) left is not credited to the first candidate.
    g.cur = relinearise(g.sx, g.st);
    g.baseline = moved_structure(g.sx.cx, g.cur.fit.beta_full);
    g.baseline_resid = g.strict_resid = g.cur.cv_resid;
    g.baseline_gap = g.final_gap = gap_deg(g.cur.fit.cv_rss);
    return g;
  };
  auto grow = [&](Grown& g) {
    Search& sx = g.sx;
    State& st = g.st;
    CurrentFit& cur = g.cur;
    VectorXd& strict_resid = g.strict_resid;
    for (int step = 1; step <= opt.max_steps; ++step) {
      say("step " + std::to_string(step) + ": fitting " + std::to_string(core::kEffectCount) + " candidate effects");
      const std::vector<CandidateResult> cands = evaluate_all(sx, st, cur, opt.threads);
      const double n_eff = cv::effective_n(cur.cv_resid);
      const double rss0 = cur.fit.cv_rss;
      json scores = json::object();
      std::vector<std::pair<double, std::size_t>> order;  // (delta BIC, candidate), best first
      for (std::size_t i = 0; i < cands.size(); ++i) {
        const CandidateResult& c = cands[i];
        const std::string id(core::to_string(c.effect));
        if (!c.applicable) { scores[id] = {{"applicable", false}, {"note", c.note}}; continue; }
        const double red = 1.0 - std::sqrt(c.fit.cv_rss / rss0);
        const double dbic = n_eff * std::log(c.fit.cv_rss / rss0) + c.n_params * std::log(n_eff);
        scores[id] = {{"heldout_gap_deg", gap_deg(c.fit.cv_rss)}, {"reduction_pct", 100 * red}, {"delta_bic", dbic},
                      {"parameters", c.n_params}};
        if (std::isfinite(dbic)) order.emplace_back(dbic, i);  // (a residual of exactly 0 leaves nothing to rank)
      }
      std::sort(order.begin(), order.end());
      auto passes = [&](std::size_t i) {
        const double red = 1.0 - std::sqrt(cands[i].fit.cv_rss / rss0);
        return red >= opt.min_reduction && -scores[std::string(core::to_string(cands[i].effect))]["delta_bic"].get<double>() > opt.min_delta_bic;
      };
      // Parsimony between nested effects: the general one must beat the simpler one it generalises
      // by the acceptance rule, as a further step on top of it would have to.
      auto parsimonious = [&](std::size_t i) {
        const auto simpler = effect_def(cands[i].effect).generalises;
        if (!simpler) return i;
        const auto si = static_cast<std::size_t>(*simpler);
        if (!cands[si].applicable) return i;
        const double red_over = 1.0 - std::sqrt(cands[i].fit.cv_rss / cands[si].fit.cv_rss);
        const double dbic_over = n_eff * std::log(cands[i].fit.cv_rss / cands[si].fit.cv_rss) +
                                 (cands[i].n_params - cands[si].n_params) * std::log(n_eff);
        if (red_over >= opt.min_reduction && -dbic_over > opt.min_delta_bic) return i;
        scores[std::string(core::to_string(cands[i].effect))]["not_preferred_to"] = std::string(core::to_string(*simpler));
        return si;
      };
      // The first candidate, best delta BIC first, that passes the rule and whose magnitude its
      // jackknife tells apart from zero (|x| > 2 SE: a 4 +- 3 ms delay is no finding).
      std::optional<Assessment> chosen;
      std::vector<std::size_t> tried;
      for (const auto& [dbic, i0] : order) {
        if (!passes(i0)) break;
        const std::size_t i = parsimonious(i0);
        if (!passes(i) || std::find(tried.begin(), tried.end(), i) != tried.end()) continue;
        tried.push_back(i);
        Assessment a = assess(sx, st, cands[i], cur.d.X.cols());
        if (a.significant) { chosen = std::move(a); break; }
        scores[std::string(core::to_string(cands[i].effect))]["not_significant"] = a.significance;
        say("step " + std::to_string(step) + ": " + std::string(core::to_string(cands[i].effect)) + " " + a.significance);
      }
      if (!chosen) {
        if (!order.empty()) {
          const CandidateResult& b = cands[order.front().second];
          const double red = 1.0 - std::sqrt(b.fit.cv_rss / rss0);
          say("step " + std::to_string(step) + ": best " + std::string(core::to_string(b.effect)) + " (" + fmt(100 * red, 1) +
              " %, dBIC " + fmt(order.front().first, 1) + "): not significant, stopping");
          g.last_rejected = {{"effect", std::string(core::to_string(b.effect))}, {"reduction_pct", 100 * red},
                                            {"delta_bic", order.front().first}, {"all", scores}};
        }
        break;
      }
      const CandidateResult& w = *chosen->candidate;
      const EffectDef& def = effect_def(w.effect);
      const std::string wid(core::to_string(w.effect));
      const double red = 1.0 - std::sqrt(w.fit.cv_rss / rss0);
      const double wbic = scores[wid]["delta_bic"].get<double>();
      say("step " + std::to_string(step) + ": " + wid + " (held-out gap " + fmt(gap_deg(rss0)) + " -> " +
          fmt(gap_deg(w.fit.cv_rss)) + " deg, " + fmt(100 * red, 1) + " %, dBIC " + fmt(wbic, 1) + "): accepted");

      // Where: the part of the residual this effect explains, localised.
      const VectorXd explained = to_deg(VectorXd(cur.cv_resid - chosen->after));
      const Localisation loc = localise(explained, s, k0, phases);
      const Localisation before_loc = localise(to_deg(cur.cv_resid), s, k0, phases);
      Step stp;
      stp.effect = wid;
      stp.gap_deg = gap_deg(w.fit.cv_rss);
      stp.where = loc.sentence;
      stp.parameters = chosen->parameters;
      std::string runner_up;
      double runner_bic = 0;
      for (const auto& [dbic, i] : order)
        if (cands[i].effect != w.effect) { runner_up = std::string(core::to_string(cands[i].effect)); runner_bic = dbic; break; }
      stp.evidence = {{"heldout_gap_before_deg", gap_deg(rss0)},
                      {"heldout_gap_after_deg", stp.gap_deg},
                      {"reduction_pct", 100 * red},
                      {"delta_bic", wbic},
                      {"n_eff", n_eff},
                      {"meaning", std::string(def.meaning)},
                      {"significance", chosen->significance},
                      {"runner_up", runner_up},
                      {"runner_up_delta_bic", runner_bic},
                      {"residual_before_where", before_loc.sentence},
                      {"phase_rms_before_deg", phase_rms(to_deg(cur.cv_resid), phases)},
                      {"phase_rms_after_deg", phase_rms(to_deg(chosen->after), phases)},
                      {"explained_localisation", loc.detail},
                      {"candidates", scores}};
      g.steps.push_back(stp);
      const double th_full = w.grid.empty() ? 0.0 : w.grid[w.fit.full_idx];
      st = st.with(w.effect, th_full);
      sx.cx.m = w.base.paper;
      sx.cx.dyn = w.base.dynamic;
      if (st.size() > 1) refit_thetas(sx, st, chosen->after);
      // The next ranking compares candidates with the state refitted the same way they are (accepted
      // nonlinear parameters fixed); the reported gaps stay the strict per-fold ones.
      cur = relinearise(sx, st);
      g.steps.back().evidence["heldout_gap_refitted_deg"] = gap_deg(cur.fit.cv_rss);
      strict_resid = chosen->after;
    }
    g.final_gap = g.steps.empty() ? g.baseline_gap : g.steps.back().gap_deg;
  };

  // The paper structure first; then the second baseline, the dynamic model fitted to the recording
  // (docs/gap.md, section 1). Two explanations are compared by their final held-out gap with every
  // accepted effect charged the acceptance rule's margin (gap / (1 - min_reduction)^steps, the
  // reduction an effect had to buy to be accepted): the same loop told by stop operators and
  // Prony terms in the structure, or by memory and creep terms on the paper's steps, is one
  // explanation, and the shorter one is preferred unless the longer is better by what its extra
  // effects cost. A paper-structure sensor with a creep keeps the paper structure and names the
  // creep; a fibre whose memory and relaxation are its own gets the dynamic model and no effect.
  const double margin = 1.0 - opt.min_reduction;
  auto charged = [&](const Grown& g) { return g.final_gap / std::pow(margin, static_cast<double>(g.steps.size())); };
  say("baseline: the paper's structure");
  Grown chosen = start(sx0);
  say("baseline: held-out gap " + fmt(chosen.baseline_gap) + " deg");
  grow(chosen);
  json choice = {{"paper", {{"heldout_gap_deg", chosen.baseline_gap}, {"final_gap_deg", chosen.final_gap},
                            {"steps", chosen.steps.size()}, {"charged_gap_deg", charged(chosen)}}}};
  if (base.dynamic) {
    Search sd = sx0;
    sd.cx.dyn = sd.cx.dyn_origin = base.dynamic;
    Grown dyn = start(sd);
    choice["dynamic"] = {{"heldout_gap_deg", dyn.baseline_gap}};
    // Searched from when its structure alone beats the paper structure alone, or is not worse than
    // the paper structure's charged final gap, by the margin either way: a dynamic structure
    // missing one effect can lose to the paper structure with three, and win once it has that one.
    if (dyn.baseline_gap < margin * chosen.baseline_gap || dyn.baseline_gap * margin < charged(chosen)) {
      say("baseline: the dynamic model (held-out gap " + fmt(dyn.baseline_gap) + " deg; the paper structure with its " +
          "effects " + fmt(chosen.final_gap) + " deg): searching from it too");
      grow(dyn);
      choice["dynamic"]["final_gap_deg"] = dyn.final_gap;
      choice["dynamic"]["steps"] = dyn.steps.size();
      choice["dynamic"]["charged_gap_deg"] = charged(dyn);
      if (charged(dyn) < charged(chosen)) {
        choice["why"] = "the dynamic model with its effects has the lower held-out gap, each effect charged " +
                        fmt(100 * opt.min_reduction, 0) + " %";
        chosen = std::move(dyn);
      } else {
        choice["why"] = "the paper structure with its effects has the lower (or equal) held-out gap, each effect charged " +
                        fmt(100 * opt.min_reduction, 0) + " %";
      }
    } else {
      choice["dynamic"]["not_searched"] = "its structure alone does not beat the paper structure alone, and is worse than the "
                                          "paper structure's charged final gap, by " + fmt(100 * opt.min_reduction, 0) + " %";
    }
  }
  const Search& fin = chosen.sx;
  choice["chosen"] = fin.cx.dyn ? "dynamic" : "paper";
  const Structure baseline_model = chosen.baseline;
  res.baseline_gap_deg = chosen.baseline_gap;
  res.steps = chosen.steps;
  if (!chosen.last_rejected.is_null()) res.whiteness["last_rejected"] = chosen.last_rejected;
  {
    const Localisation loc = localise(to_deg(chosen.baseline_resid), s, k0, phases);
    res.baseline = base.detail;
    res.baseline["choice"] = choice;
    res.baseline["structure"] = choice["chosen"];
    if (baseline_model.dynamic) res.baseline["dynamic"]["model"] = io::dynamic_model_json(*baseline_model.dynamic);
    res.baseline["c9_deg_per_v"] = base.model.c9;
    res.baseline["c10_deg"] = base.model.c10;
    res.baseline["heldout_gap_deg"] = res.baseline_gap_deg;
    res.baseline["where"] = loc.sentence;
    res.baseline["localisation"] = loc.detail;
  }
  const VectorXd resid_baseline = to_deg(chosen.baseline_resid);
  const VectorXd model_baseline = s.v - chosen.baseline_resid;
  const VectorXd& strict_resid = chosen.strict_resid;
  const State& st = chosen.st;
  const CurrentFit& cur = chosen.cur;
  res.final_gap_deg = chosen.final_gap;

  const VectorXd rf = to_deg(strict_resid);
  {
    const Whiteness wh = whiteness(rf);
    for (auto it = wh.detail.begin(); it != wh.detail.end(); ++it) res.whiteness[it.key()] = it.value();
    res.unexplained = wh.unexplained;
    res.whiteness["final_where"] = localise(rf, s, k0, phases).sentence;
  }

  // ---- the loop closed: the compensator's angle with and without the found model --------------
  VectorXd comp_before, comp_after;
  Applied written;
  say("compensating the held-out blocks with the baseline and with the found model");
  try {
    const std::vector<bool> transition = transition_scans(k0, s.dt, core::CompensatorSettings{}.velocity_window_s);
    res.compensated = compensated_rmse(rec, fin, baseline_model, st, cur, transition, &written, &comp_before, &comp_after);
  } catch (const std::exception& e) {
    // The compensator refused a model (std::invalid_argument from its constructor): the analysis
    // stands, model.toml holds the baseline, and the report says why.
    res.compensated = {{"error", std::string("the compensator could not run the found model: ") + e.what()}};
    written.terms.assign(st.terms.size(), false);
    comp_before = comp_after = VectorXd::Constant(s.n, std::numeric_limits<double>::quiet_NaN());
  }

  // ---- improved model, fitted on all the data (what model.toml holds) ----------------------------
  // If even the effects kept make the compensator's held-out angle worse than the baseline does,
  // model.toml holds the baseline: a file that degrades the controller's angle helps no one (the
  // effects stay named in gap.json and the report).
  const bool write_baseline =
      !res.steps.empty() && (res.compensated.contains("error") || !(res.compensated["rmse_written_deg"].get<double>() <
                                                                    res.compensated["rmse_before_deg"].get<double>()));
  res.compensated["model_toml"] = write_baseline ? "baseline (the found model made the held-out angle worse)" : "found model";
  if (write_baseline) {
    // rmse_written_deg is what model.toml holds: the baseline's now (the kept terms' was not lower).
    res.compensated["rmse_written_deg"] = res.compensated["rmse_before_deg"];
    written.delay = written.backlash = false;
    written.terms.assign(written.terms.size(), false);
  }
  {
    const VectorXd b = cur.fit.beta_full;
    const Structure mm = write_baseline ? baseline_model : moved_structure(fin.cx, b);
    const core::GapModel g = gap_model_of(st, b, fin.cx);
    json terms = json::array();
    for (std::size_t i = 0; i < g.terms.size(); ++i) {
      if (!written.terms[i]) continue;  // its online application made the held-out angle worse
      const core::GapTerm& t = g.terms[i];
      json term = {{"effect", t.effect}, {"theta", t.theta}, {"coefficients_v", t.coefficients_v}};
      if (!t.thresholds_deg.empty()) term["thresholds_deg"] = t.thresholds_deg;
      if (!t.time_constants_s.empty()) term["time_constants_s"] = t.time_constants_s;
      json p = json::object();
      for (const auto& [k, v] : t.parameters) p[k] = v;
      term["parameters"] = p;
      terms.push_back(term);
    }
    res.model = coefficients_json(mm.paper);
    res.model["structure"] = mm.dynamic ? "dynamic" : "paper";
    if (mm.dynamic) res.model["dynamic"] = io::dynamic_model_json(*mm.dynamic);
    res.dynamic_model = mm.dynamic;
    res.model.update({{"reference_level_v", s.reference_level_v}, {"delay_s", written.delay ? st.delay_s : 0.0},
                      {"backlash_deg", written.backlash ? st.backlash_deg : 0.0}, {"duration_s", fin.cx.duration_s},
                      {"terms", terms}, {"left_out", res.compensated.value("left_out_of_model", json::array())}});
    describe_range(res.model, s, k0);
  }

  // ---- plot series (at most ~40k rows) ----------------------------------------------------------
  const Index stride = std::max<Index>(1, s.n / 40000);
  const VectorXd model_final = s.v - strict_resid;
  for (Index i = 0; i < s.n; i += stride) {
    res.series.t.push_back(s.t(i));
    res.series.angle.push_back(s.angle(i));
    res.series.w.push_back(k0.w(i));
    res.series.v.push_back(s.v(i));
    res.series.model_baseline.push_back(model_baseline(i));
    res.series.model_final.push_back(model_final(i));
    res.series.resid_baseline_deg.push_back(resid_baseline(i));
    res.series.resid_final_deg.push_back(rf(i));
    res.series.angle_comp_before.push_back(comp_before(i));
    res.series.angle_comp_after.push_back(comp_after(i));
  }
  say("done: held-out gap " + fmt(res.baseline_gap_deg) + " -> " + fmt(res.final_gap_deg) + " deg in " +
      std::to_string(res.steps.size()) + " step(s)");
  return res;
}

}  // namespace pof::gap
