// The compensated angle before and after the found model (see compensation.hpp).
#include "compensation.hpp"

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
  Index c = kBaseCols;
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

nlohmann::json compensated_rmse(const io::Recording& rec, const Search& sx, const core::ModelCoefficients& before, const State& st,
                                const CurrentFit& after, VectorXd* angle_before, VectorXd* angle_after) {
  const Signals& s = *sx.cx.s;
  const double rate = 1.0 / s.dt;
  core::Calibration base;
  base.model = before;
  base.reference_level_v = s.reference_level_v;
  base.angle_min_deg = s.angle.minCoeff();
  base.angle_max_deg = s.angle.maxCoeff();
  const VectorXd a0 = compensate(rec, base, rate);
  VectorXd a1 = a0;
  nlohmann::json out;
  nlohmann::json not_applied = nlohmann::json::array();
  nlohmann::json folds = nlohmann::json::array();
  double ss0 = 0, ss1 = 0;
  Index n = 0;
  for (std::size_t f = 0; f < sx.blocks.size(); ++f) {
    core::Calibration cal = base;
    cal.model = moved_model(sx.cx.m, after.fit.beta[f]);
    core::GapModel g = gap_model_of(st, after.fit.beta[f], sx.cx);
    // What the compensator cannot apply online is left out here, as a user would have to.
    std::vector<core::GapTerm> kept;
    for (std::size_t t = 0; t < g.terms.size(); ++t) {
      core::GapModel one;
      one.terms = {g.terms[t]};
      if (core::gap_problems(one, rate).empty()) kept.push_back(g.terms[t]);
      else if (f == 0) not_applied.push_back(g.terms[t].effect);
    }
    g.terms = std::move(kept);
    if (!g.empty()) cal.gap = std::move(g);
    const VectorXd af = compensate(rec, cal, rate);
    const Index b = sx.blocks.start[f], l = sx.blocks.len[f];
    a1.segment(b, l) = af.segment(b, l);
    const double r0 = rms_of(a0, rec.angle_ref_deg, b, l), r1 = rms_of(af, rec.angle_ref_deg, b, l);
    folds.push_back({{"rmse_before_deg", r0}, {"rmse_after_deg", r1}});
    if (std::isfinite(r0) && std::isfinite(r1)) {
      ss0 += r0 * r0 * static_cast<double>(l);
      ss1 += r1 * r1 * static_cast<double>(l);
      n += l;
    }
  }
  const double before_deg = n > 0 ? std::sqrt(ss0 / static_cast<double>(n)) : std::numeric_limits<double>::quiet_NaN();
  const double after_deg = n > 0 ? std::sqrt(ss1 / static_cast<double>(n)) : std::numeric_limits<double>::quiet_NaN();
  out = {{"rmse_before_deg", before_deg},
         {"rmse_after_deg", after_deg},
         {"reduction_pct", before_deg > 0 ? 100.0 * (1.0 - after_deg / before_deg) : 0.0},
         {"folds", folds},
         {"not_applied", not_applied},
         {"how", "core::OnlineCompensator over the recording (velocity from the sensor); before: the baseline "
                 "fitted to the recording; after: per fold, the model fitted on the other folds, scored on the "
                 "held-out block against angle_ref_deg"}};
  if (angle_before != nullptr) *angle_before = a0;
  if (angle_after != nullptr) *angle_after = a1;
  return out;
}

}  // namespace pof::gap
