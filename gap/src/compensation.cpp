// The compensated angle before and after the found model (see compensation.hpp).
#include "compensation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "pof/core/calibration.hpp"
#include "pof/core/compensator.hpp"

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
    for (Index i = 0; i < def.linear; ++i) term.coefficients_v.push_back(beta(c + i));
    term.coefficients_v.resize(static_cast<std::size_t>(std::max(def.linear, def.file_coefficients)), 0.0);
    if (def.basis_values != nullptr) {
      const std::vector<double> b = def.basis_values(t.theta);
      if (def.basis_key == "thresholds_deg") term.thresholds_deg = b;
      else term.time_constants_s = b;
    }
    const nlohmann::json p = def.physical(t.theta, beta.segment(c, def.linear), cx);
    for (auto it = p.begin(); it != p.end(); ++it) term.parameters.emplace_back(it.key(), it.value().get<double>());
    g.terms.push_back(std::move(term));
    c += def.linear;
  }
  return g;
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

double rms_of(const VectorXd& a, const VectorXd& ref, Index start, Index len) {
  double ss = 0;
  Index n = 0;
  for (Index i = start; i < start + len; ++i)
    if (std::isfinite(a(i))) { ss += (a(i) - ref(i)) * (a(i) - ref(i)); ++n; }
  return n > 0 ? std::sqrt(ss / static_cast<double>(n)) : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

namespace {

struct HeldOut {
  double rmse_deg = 0;
  nlohmann::json folds = nlohmann::json::array();
  VectorXd angle;  // block by block, the angle of the model fitted on the other blocks
};

// The compensator's angle with the state's terms (those `use` keeps), fold by fold with the model
// fitted on the other folds, scored on the held-out blocks. Terms the compensator refuses are
// skipped and named in not_applied.
HeldOut held_out(const io::Recording& rec, const Search& sx, const State& st,
                 const CurrentFit& after, const Applied& use, const VectorXd& a0, nlohmann::json* not_applied) {
  const Signals& s = *sx.cx.s;
  const double rate = 1.0 / s.dt;
  HeldOut h;
  h.angle = a0;
  double ss = 0;
  Index n = 0;
  for (std::size_t f = 0; f < sx.blocks.size(); ++f) {
    core::Calibration cal = calibration_of(moved_structure(sx.cx, after.fit.beta[f]), s);
    core::GapModel g = gap_model_of(st, after.fit.beta[f], sx.cx);
    if (!use.delay) g.delay_s = 0;
    if (!use.backlash) g.backlash_deg = 0;
    std::vector<core::GapTerm> kept;
    for (std::size_t t = 0; t < g.terms.size(); ++t) {
      if (t < use.terms.size() && !use.terms[t]) continue;
      core::GapModel one;
      one.terms = {g.terms[t]};
      if (core::gap_problems(one, rate).empty()) kept.push_back(g.terms[t]);
      else if (f == 0 && not_applied != nullptr) not_applied->push_back(g.terms[t].effect);
    }
    g.terms = std::move(kept);
    if (!g.empty()) cal.gap = std::move(g);
    const VectorXd af = compensate(rec, cal, rate);
    const Index b = sx.blocks.start[f], l = sx.blocks.len[f];
    h.angle.segment(b, l) = af.segment(b, l);
    const double r0 = rms_of(a0, rec.angle_ref_deg, b, l), r1 = rms_of(af, rec.angle_ref_deg, b, l);
    h.folds.push_back({{"rmse_before_deg", r0}, {"rmse_after_deg", r1}});
    if (std::isfinite(r1)) {
      ss += r1 * r1 * static_cast<double>(l);
      n += l;
    }
  }
  h.rmse_deg = n > 0 ? std::sqrt(ss / static_cast<double>(n)) : std::numeric_limits<double>::quiet_NaN();
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
  }
  cal.reference_level_v = s.reference_level_v;
  cal.angle_min_deg = s.angle.minCoeff();
  cal.angle_max_deg = s.angle.maxCoeff();
  return cal;
}

nlohmann::json compensated_rmse(const io::Recording& rec, const Search& sx, const Structure& before,
                                const State& st, const CurrentFit& after, const std::vector<bool>& transition,
                                Applied* written, VectorXd* angle_before, VectorXd* angle_after) {
  const Signals& s = *sx.cx.s;
  const double rate = 1.0 / s.dt;
  const core::Calibration base = calibration_of(before, s);
  const VectorXd a0 = compensate(rec, base, rate);
  double ss0 = 0;
  Index n0 = 0;
  for (std::size_t f = 0; f < sx.blocks.size(); ++f) {
    const double r0 = rms_of(a0, rec.angle_ref_deg, sx.blocks.start[f], sx.blocks.len[f]);
    if (std::isfinite(r0)) { ss0 += r0 * r0 * static_cast<double>(sx.blocks.len[f]); n0 += sx.blocks.len[f]; }
  }
  const double before_deg = n0 > 0 ? std::sqrt(ss0 / static_cast<double>(n0)) : std::numeric_limits<double>::quiet_NaN();
  Applied all;
  all.terms.assign(st.terms.size(), true);
  nlohmann::json not_applied = nlohmann::json::array();
  const HeldOut with_all = held_out(rec, sx, st, after, all, a0, &not_applied);

  // Each accepted effect left out in turn: one whose online application makes the held-out angle
  // worse (by > 2 %) is not written to model.toml (it stays named in the report). The choice is
  // made on the same held-out blocks it is reported on, so rmse_written_deg is optimistic;
  // rmse_after_deg (every appliable term) is the unbiased figure.
  Applied keep = all;
  nlohmann::json left_out = nlohmann::json::array();
  auto try_without = [&](const std::string& effect, auto clear) {
    Applied without = all;
    clear(without);
    const HeldOut h = held_out(rec, sx, st, after, without, a0, nullptr);
    if (h.rmse_deg < 0.98 * with_all.rmse_deg) {
      clear(keep);
      left_out.push_back({{"effect", effect}, {"rmse_with_deg", with_all.rmse_deg}, {"rmse_without_deg", h.rmse_deg}});
    }
  };
  if (st.delay_s != 0) try_without("time_delay", [](Applied& a) { a.delay = false; });
  if (st.backlash_deg > 0) try_without("backlash", [](Applied& a) { a.backlash = false; });
  for (std::size_t t = 0; t < st.terms.size(); ++t)
    try_without(std::string(core::to_string(st.terms[t].effect)), [t](Applied& a) { a.terms[t] = false; });
  const double written_deg = left_out.empty() ? with_all.rmse_deg
                                              : held_out(rec, sx, st, after, keep, a0, nullptr).rmse_deg;
  // Outside the transitions (see compensation.hpp); every scan belongs to one held-out block.
  double sb = 0, sa = 0, st_all = 0;
  Index ns = 0;
  for (Index i = 0; i < a0.size(); ++i) {
    const double eb = a0(i) - rec.angle_ref_deg(i), ea = with_all.angle(i) - rec.angle_ref_deg(i);
    if (!std::isfinite(eb) || !std::isfinite(ea)) continue;
    st_all += eb * eb;
    if (transition[static_cast<std::size_t>(i)]) continue;
    sb += eb * eb;
    sa += ea * ea;
    ++ns;
  }
  const double steady_before = ns > 0 ? std::sqrt(sb / static_cast<double>(ns)) : std::numeric_limits<double>::quiet_NaN();
  const double steady_after = ns > 0 ? std::sqrt(sa / static_cast<double>(ns)) : std::numeric_limits<double>::quiet_NaN();
  nlohmann::json steady = {
      {"rmse_before_deg", steady_before},
      {"rmse_after_deg", steady_after},
      {"reduction_pct", steady_before > 0 ? 100.0 * (1.0 - steady_after / steady_before) : 0.0},
      {"share_of_scans", static_cast<double>(ns) / static_cast<double>(a0.size())},
      {"transition_share_of_squared_error_before", st_all > 0 ? 1.0 - sb / st_all : 0.0},
      {"how", "the scans more than 0.5 s (the compensator's velocity window) after every start, stop and reversal "
              "of the reference"}};
  if (written != nullptr) *written = keep;
  if (angle_before != nullptr) *angle_before = a0;
  if (angle_after != nullptr) *angle_after = with_all.angle;
  return {{"rmse_before_deg", before_deg},
          {"rmse_after_deg", with_all.rmse_deg},
          {"reduction_pct", before_deg > 0 ? 100.0 * (1.0 - with_all.rmse_deg / before_deg) : 0.0},
          {"folds", with_all.folds},
          {"not_applied", not_applied},
          {"left_out_of_model", left_out},
          {"rmse_written_deg", written_deg},
          {"steady", steady},
          {"how", "core::OnlineCompensator over the recording (velocity from the sensor); before: the baseline "
                  "fitted to the recording; after: per fold, the model fitted on the other folds, scored on the "
                  "held-out block against angle_ref_deg"}};
}

}  // namespace pof::gap
