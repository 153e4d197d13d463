#include "pof/io/report_json.hpp"

#include <cmath>

namespace pof::io {

namespace {

using nlohmann::json;

json vec(const Eigen::VectorXd& v) {
  json a = json::array();
  for (const double x : v) a.push_back(x);
  return a;
}

json line(const pof::core::LinearFit& f) {
  return {{"slope", f.slope}, {"intercept", f.intercept}, {"slope_se", f.slope_se}, {"intercept_se", f.intercept_se},
          {"r2", f.r2}, {"rmse", f.rmse}, {"n", f.n}};
}

json cycle_json(const pof::core::CycleStats& c, bool with_cycle) {
  json j;
  if (with_cycle) j["cycle"] = c.cycle;
  j["velocity_rad_s"] = c.velocity_rad_s;
  j["rmse_comp_deg"] = c.rmse_comp_deg;
  j["rmse_uncomp_deg"] = c.rmse_uncomp_deg;
  j["hysteresis_comp_pct"] = c.hysteresis_comp_pct;
  j["hysteresis_uncomp_pct"] = c.hysteresis_uncomp_pct;
  j["max_error_deg"] = c.max_error_deg;
  j["max_error_angle_deg"] = c.max_error_angle_deg;
  j["n_samples"] = c.n_samples;
  if (with_cycle) {
    j["t_start_s"] = c.t_start_s;
    j["t_end_s"] = c.t_end_s;
  } else {
    j["cycles"] = c.cycle;
  }
  return j;
}

// NaN/inf -> null, recursively.
void scrub(json& j) {
  if (j.is_number_float() && !std::isfinite(j.get<double>())) j = nullptr;
  else if (j.is_structured())
    for (auto& e : j) scrub(e);
}

json held(const pof::core::HeldOutError& e) {
  return {{"rmse_deg", e.rmse_deg}, {"p99_abs_deg", e.p99_abs_deg}, {"max_abs_deg", e.max_abs_deg}, {"n", e.n}};
}

}  // namespace

json dynamic_model_json(const pof::core::DynamicModel& m) {
  json j;
  j["degree"] = m.degree;
  j["angle_centre_deg"] = m.angle_centre_deg;
  j["angle_scale_deg"] = m.angle_scale_deg;
  j["poly"] = std::vector<double>(m.poly.begin(), m.poly.begin() + m.degree + 1);
  j["thresholds_deg"] = std::vector<double>(m.threshold_deg.begin(), m.threshold_deg.begin() + m.n_operators);
  j["weights_v_per_deg"] = std::vector<double>(m.weight_v_per_deg.begin(), m.weight_v_per_deg.begin() + m.n_operators);
  j["loop_half_height_v"] = m.loop_half_height_v();
  j["rate_gain_s_per_rad"] = m.rate_gain_s_per_rad;
  j["prony_tau_s"] = std::vector<double>(m.prony_tau_s.begin(), m.prony_tau_s.begin() + m.n_prony);
  j["prony_gain_v_per_deg"] = std::vector<double>(m.prony_gain_v_per_deg.begin(), m.prony_gain_v_per_deg.begin() + m.n_prony);
  j["bend_lag_s"] = m.bend_lag_s;
  j["lag_window_s"] = m.lag_window_s;
  return j;
}

json dynamic_report(const pof::core::DynamicFitResult& d, const pof::core::ModelComparison* c) {
  json j = dynamic_model_json(d.model);
  j["train_rmse_deg"] = d.train_rmse_deg;
  j["cv_rmse_deg"] = d.chosen.cv_rmse_deg;
  j["sensitivity_v_per_deg"] = d.sensitivity_v_per_deg;
  json cs = json::array();
  for (const auto& k : d.candidates)
    cs.push_back({{"degree", k.degree}, {"n_operators", k.n_operators}, {"n_prony", k.n_prony},
                  {"rate_gain_s_per_rad", k.rate_gain_s_per_rad}, {"bend_lag_s", k.bend_lag_s}, {"cv_rmse_deg", k.cv_rmse_deg}, {"admissible", k.admissible}});
  // Only when the constrained search ran (DynamicFitResult::unconstrained): which structures it
  // scored, whether it chose one, and what the fit without the invertibility rule says of the sensor.
  if (d.unconstrained) {
    for (std::size_t i = 0; i < d.candidates.size(); ++i) cs[i]["constrained"] = d.candidates[i].constrained;
    j["constrained"] = d.chosen.constrained;
    j["unconstrained"] = {{"degree", d.unconstrained->degree}, {"n_operators", d.unconstrained->n_operators},
                          {"n_prony", d.unconstrained->n_prony}, {"rate_gain_s_per_rad", d.unconstrained->rate_gain_s_per_rad},
                          {"bend_lag_s", d.unconstrained->bend_lag_s}, {"cv_rmse_deg", d.unconstrained->cv_rmse_deg},
                          {"backwards_deg", d.backwards_deg}, {"backwards_ambiguity_deg", d.backwards_ambiguity_deg}};
  }
  j["candidates"] = cs;
  if (c != nullptr) {
    j["held_out"] = {{"paper", held(c->paper)}, {"dynamic", held(c->dynamic)}, {"folds", c->folds},
                     {"folds_used", c->folds_used}, {"notes", c->notes}};
  }
  return j;
}

json calibration_report(const pof::core::CalibrationResult& r) {
  using pof::core::Direction;
  const auto& m = r.cal.model;
  json j;
  j["reference_level_v"] = r.cal.reference_level_v;
  j["n_reference_rejected"] = r.n_reference_rejected;
  j["quasi_static"] = {
      {"c9", m.c9},
      {"c10", m.c10},
      {"sensitivity_v_per_deg", std::abs(r.quasi_static.v_of_angle.slope)},
      {"linearity_r2", r.quasi_static.v_of_angle.r2},
      {"angle_of_v", line(r.quasi_static.angle_of_v)},
      {"v_of_angle", line(r.quasi_static.v_of_angle)},
      {"hold_v", vec(r.quasi_static.hold_v)},
      {"hold_angle_deg", vec(r.quasi_static.hold_angle_deg)},
      {"residuals_deg", vec(r.quasi_static.angle_of_v.residuals)}};
  json tests = json::array();
  for (const auto& t : r.tests)
    tests.push_back({{"velocity_rad_s", t.velocity_rad_s},
                     {"n_flexion_sweeps", t.n_flexion},
                     {"n_extension_sweeps", t.n_extension},
                     {"n_samples", t.n_samples},
                     {"hysteresis_pct", t.h_pct},
                     {"hysteresis_signed_pct", t.hysteresis.pct},
                     {"hysteresis_x_mid_deg", t.hysteresis.x_mid},
                     {"hysteresis_span_v", t.hysteresis.span},
                     {"f1_pct", r.f1(t.velocity_rad_s)},
                     {"f3_flexion", line(t.f3_flexion)},
                     {"f3_extension", line(t.f3_extension)}});
  j["velocity_tests"] = tests;
  j["f1"] = {{"c1", r.f1.c1}, {"c2", r.f1.c2}, {"c1_se", r.f1.c1_se}, {"c2_se", r.f1.c2_se}, {"r2", r.f1.r2},
             {"rmse_pct", r.f1.rmse}, {"iterations", r.f1.iterations}, {"converged", r.f1.converged},
             {"residuals_pct", vec(r.f1.residuals)}};
  j["f2"] = {{"a_flexion", line(r.f2_a_flexion)}, {"b_flexion", line(r.f2_b_flexion)},
             {"a_extension", line(r.f2_a_extension)}, {"b_extension", line(r.f2_b_extension)}};
  j["f4"] = {{"flexion", line(r.f4_flexion)}, {"extension", line(r.f4_extension)}};
  auto dir = [](const pof::core::DirectionCoefficients& x) {
    return json{{"c3", x.c3}, {"c4", x.c4}, {"c5", x.c5}, {"c6", x.c6}, {"c7", x.c7}, {"c8", x.c8}};
  };
  j["coefficients"] = {{"c1", m.c1}, {"c2", m.c2}, {"c9", m.c9}, {"c10", m.c10},
                       {"flexion", dir(m.flexion)}, {"extension", dir(m.extension)}};
  auto eq = [](const pof::core::CombinedEquation& e, Direction d) {
    return json{{"a1", e.a1}, {"a0", e.a0}, {"b1", e.b1}, {"b0", e.b0}, {"c2", e.c2},
                {"text", format_combined_equation(e, d)}};
  };
  j["combined"] = {{"eq11_flexion", eq(r.eq11, Direction::kFlexion)}, {"eq12_extension", eq(r.eq12, Direction::kExtension)}};
  j["range"] = {{"angle_min_deg", r.cal.angle_min_deg}, {"angle_max_deg", r.cal.angle_max_deg},
                {"velocity_min_rad_s", r.cal.velocity_min_rad_s}, {"velocity_max_rad_s", r.cal.velocity_max_rad_s}};
  json segs = json::array();
  for (const auto& s : r.segments)
    segs.push_back({{"kind", s.kind == Direction::kHold ? "hold" : s.kind == Direction::kFlexion ? "flexion" : "extension"},
                    {"t_begin_s", s.t_begin}, {"t_end_s", s.t_end}, {"angle_begin_deg", s.angle_begin},
                    {"angle_end_deg", s.angle_end}, {"velocity_rad_s", s.velocity_rad_s}});
  j["segments"] = segs;
  return j;
}

json statistics_report(const std::vector<pof::core::CycleStats>& cycles, const pof::core::CycleStats& overall,
                       const pof::core::ErrorProfile& profile) {
  json j;
  j["cycles"] = json::array();
  for (const auto& c : cycles) j["cycles"].push_back(cycle_json(c, true));
  j["overall"] = cycle_json(overall, false);
  json prof = json::array();
  for (int b = 0; b < pof::core::ErrorProfile::kBins; ++b) {
    const auto k = static_cast<std::size_t>(b);
    const auto n = profile.count[k];
    if (n == 0) continue;
    const double dn = static_cast<double>(n);
    prof.push_back({{"angle_deg", pof::core::ErrorProfile::centre(b)},
                    {"n", n},
                    {"mean_error_comp_deg", profile.sum_comp[k] / dn},
                    {"mean_error_uncomp_deg", profile.sum_uncomp[k] / dn},
                    {"mean_abs_error_comp_deg", profile.sum_abs_comp[k] / dn},
                    {"mean_abs_error_uncomp_deg", profile.sum_abs_uncomp[k] / dn}});
  }
  j["error_profile"] = prof;
  return j;
}

std::string dump(const nlohmann::json& j) {
  nlohmann::json c = j;
  scrub(c);
  return c.dump(2) + "\n";
}

}  // namespace pof::io
