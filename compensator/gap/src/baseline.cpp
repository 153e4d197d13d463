// The baseline structure fitted to the recording (see baseline.hpp).
#include "baseline.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "pof/core/calibration.hpp"
#include "pof/core/dynamic_fit.hpp"
#include "pof/core/paper_refit.hpp"

namespace pof::gap {

nlohmann::json coefficients_json(const core::ModelCoefficients& m) {
  auto dir = [](const core::DirectionCoefficients& x) { return nlohmann::json::array({x.c3, x.c4, x.c5, x.c6, x.c7, x.c8}); };
  return {{"c1", m.c1}, {"c2", m.c2}, {"c9", m.c9}, {"c10", m.c10}, {"flexion", dir(m.flexion)}, {"extension", dir(m.extension)}};
}

Baseline fit_baseline(const io::Recording& rec, const Signals& s, const Kinematics& k0) {
  Baseline b;
  nlohmann::json& d = b.detail;
  core::ModelCoefficients start = core::paper_coefficients();
  try {
    core::CalibrationSettings cs;
    cs.reference_level_v = s.reference_level_v;  // the same normalisation as the gap's v
    const core::CalibrationResult cal = core::calibrate(rec.t_s, rec.sensor_v, rec.reference_v, rec.angle_ref_deg, cs);
    start = cal.cal.model;
    d["start"] = "calibration procedure (pof calibrate): f5 from " + std::to_string(cal.quasi_static.hold_v.size()) +
                 " holds, f1-f4 from " + std::to_string(cal.tests.size()) + " velocity tests";
  } catch (const core::CalibrationError& e) {
    d["start"] = std::string("the paper's table 2 (the calibration procedure needs: ") + e.what() + ")";
  }
  const Eigen::VectorXd speed = k0.w.cwiseAbs();
  core::PaperRefit fit = core::refit_paper_model(start, k0.angle, speed, k0.dir, s.v);
  // The calibration procedure fits f1-f4 to a few velocity tests and can start far from the
  // voltage's optimum (or where the f3 gain crosses zero at this recording's speeds); the refit
  // also runs from the paper's table 2 and the better of the two is kept.
  const core::PaperRefit alt = core::refit_paper_model(core::paper_coefficients(), k0.angle, speed, k0.dir, s.v);
  if (alt.rms_after_v > 0 && (!(fit.rms_after_v > 0) || alt.rms_after_v < fit.rms_after_v)) {
    fit = alt;
    d["start"] = d["start"].get<std::string>() + "; the refit from the paper's table 2 fitted better and was kept";
  }
  b.model = fit.model;
  d["structure"] = "paper (table 2, eqs. 11/12 inverted while moving, f5 in holds)";
  d["refit"] = "every identifiable coefficient (c2, c9, c10, c3-c6 of each direction) refitted on the voltage by "
               "Levenberg-Marquardt; per fold they move to first order (docs/gap.md, section 1)";
  d["refit_rms_mv"] = {{"start", fit.rms_before_v * 1e3}, {"refitted", fit.rms_after_v * 1e3}};
  d["refit_iterations"] = fit.iterations;
  d["coefficients"] = coefficients_json(b.model);
  try {
    const core::DynamicFitResult dyn = core::fit_dynamic(rec.t_s, s.v, s.angle);
    const core::DynamicModel& m = dyn.model;
    b.dynamic = m;
    d["dynamic"] = {{"heldout_rmse_deg", dyn.chosen.cv_rmse_deg},
                    {"degree", m.degree},
                    {"stop_operators", m.n_operators},
                    {"prony_terms", m.n_prony},
                    {"rate_gain_s_per_rad", m.rate_gain_s_per_rad},
                    {"bend_lag_s", m.bend_lag_s}};
    // The best structure without a bend lag: how much the lag itself explains (a lag and a delay
    // of the angle look alike at these speeds; analysis.cpp names a large one).
    double lag_free = std::numeric_limits<double>::infinity();
    for (const core::DynamicCandidate& c : dyn.candidates)
      if (c.admissible && c.bend_lag_s == 0 && std::isfinite(c.cv_rmse_deg)) lag_free = std::min(lag_free, c.cv_rmse_deg);
    if (std::isfinite(lag_free)) d["dynamic"]["lag_free_heldout_rmse_deg"] = lag_free;
  } catch (const core::DynamicFitError& e) {
    d["dynamic"] = {{"error", e.what()}};
  }
  return b;
}

}  // namespace pof::gap
