// Files of `pof gap` (see io.hpp).
#include "pof/gap/io.hpp"

#include <cctype>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <system_error>
#include <vector>


#include "pof/core/gap_terms.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/io/calibration_file.hpp"
#include "pof/base/errors.hpp"

namespace pof::gap {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return b;
}

// The calibration file of `pof calibrate` (pof/io/calibration_file.hpp, one writer for both), so
// `pof compensate --cal model.toml` and pof-compensatord run the refitted model with the accepted
// effects ([gap], applied online: docs/calibration.md).
std::string model_toml(const Result& r, const std::string& source) {
  const json& m = r.model;
  io::CalibrationFile f;
  f.sensor_id = "pof-gap";
  f.date = utc_now();
  f.source_recording = source;
  core::Calibration& cal = f.cal;
  auto dir = [](const json& a) {
    return core::DirectionCoefficients{a[0].get<double>(), a[1].get<double>(), a[2].get<double>(),
                                       a[3].get<double>(), a[4].get<double>(), a[5].get<double>()};
  };
  cal.model.c1 = m["c1"].get<double>();
  cal.model.c2 = m["c2"].get<double>();
  cal.model.c9 = m["c9"].get<double>();
  cal.model.c10 = m["c10"].get<double>();
  cal.model.flexion = dir(m["flexion"]);
  cal.model.extension = dir(m["extension"]);
  cal.active = core::ModelKind::kPaper;
  cal.reference_level_v = m["reference_level_v"].get<double>();
  const json& rg = m["range"];
  cal.angle_min_deg = rg["angle_min_deg"].get<double>();
  cal.angle_max_deg = rg["angle_max_deg"].get<double>();
  cal.velocity_min_rad_s = rg["velocity_min_rad_s"].get<double>();
  cal.velocity_max_rad_s = rg["velocity_max_rad_s"].get<double>();
  // `pof gap` fits the voltage, not f1-f4 one by one: their R^2 / RMSE are given as -1.
  f.quality.sensitivity_v_per_deg = 1.0 / std::abs(cal.model.c9);
  f.quality.linearity_r2 = m["linearity_r2"].get<double>();
  f.quality.f1_r2 = f.quality.f1_rmse_pct = f.quality.f4_flexion_r2 = f.quality.f4_extension_r2 = -1;
  f.quality.n_holds = m["n_holds"].get<std::int64_t>();
  f.equation_flexion = "paper eq. (11), coefficients refitted to the voltage by pof gap";
  f.equation_extension = "paper eq. (12), coefficients refitted to the voltage by pof gap";
  if (r.dynamic_model) {
    // The dynamic baseline explained the recording better: the compensator inverts it
    // (docs/calibration.md, "The dynamic model"); the paper structure stays as the fallback.
    cal.dynamic = r.dynamic_model;
    cal.active = core::ModelKind::kDynamic;
    f.dynamic_note = "pof gap: the dynamic model explained the recording better than the paper structure (gap.json, baseline.choice)";
  }
  core::GapModel g;
  g.delay_s = m["delay_s"].get<double>();
  g.backlash_deg = m["backlash_deg"].get<double>();
  for (const json& t : m["terms"]) {
    core::GapTerm term;
    term.effect = t["effect"].get<std::string>();
    term.theta = t["theta"].get<double>();
    term.coefficients_v = t["coefficients_v"].get<std::vector<double>>();
    if (t.contains("thresholds_deg")) term.thresholds_deg = t["thresholds_deg"].get<std::vector<double>>();
    if (t.contains("relay_centres_deg")) term.relay_centres_deg = t["relay_centres_deg"].get<std::vector<double>>();
    if (t.contains("time_constants_s")) term.time_constants_s = t["time_constants_s"].get<std::vector<double>>();
    for (auto it = t["parameters"].begin(); it != t["parameters"].end(); ++it)
      term.parameters.emplace_back(it.key(), it.value().get<double>());
    g.terms.push_back(std::move(term));
  }
  if (!g.empty()) cal.gap = std::move(g);
  return io::to_toml(f);
}

std::string report_md(const Result& r, const std::string& source) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(3);
  o << "# Model gap report: " << source << "\n\n";
  if (!r.complete())
    o << "**Written while the analysis ran, at: " << r.stage << ".** If this line is still here, the run stopped "
      << "before its next stage; the analysis is whole up to here. model.toml and the compensated angle come "
      << "last (docs/gap.md, section 5, \"Written as it goes\").\n\n";
  o
    << "Held-out RMS residual (time-blocked " << r.recording["folds"].get<std::size_t>() << "-fold CV) in degrees.\n\n"
    << "| step | effect | held-out gap [deg] | parameters |\n|---|---|---|---|\n"
    << "| 0 | baseline (" << (r.dynamic_model ? "dynamic model" : "paper structure")
    << ", coefficients fitted to the recording) | " << r.baseline_gap_deg << " | c9 = "
    << r.baseline["c9_deg_per_v"].get<double>() << " deg/V, c10 = " << r.baseline["c10_deg"].get<double>() << " deg |\n";
  int i = 1;
  for (const Step& s : r.steps) o << "| " << i++ << " | " << s.effect << " | " << s.gap_deg << " | `" << s.parameters.dump() << "` |\n";
  o << "\n**Baseline:** " << r.baseline["start"].get<std::string>() << ", then every identifiable coefficient refitted "
    << "on the voltage (RMS " << r.baseline["refit_rms_mv"]["start"].get<double>() << " -> "
    << r.baseline["refit_rms_mv"]["refitted"].get<double>() << " mV).";
  if (r.baseline.contains("dynamic") && r.baseline["dynamic"].contains("heldout_rmse_deg"))
    o << " Second baseline, the dynamic model (docs/calibration.md): held-out RMSE "
      << r.baseline["dynamic"]["heldout_rmse_deg"].get<double>() << " deg over its own folds.";
  if (r.baseline.contains("choice")) {
    const json& c = r.baseline["choice"];
    o << "\n\n**Baseline taken: " << (c.value("chosen", "") == "dynamic" ? "the dynamic model" : "the paper structure")
      << "** (docs/gap.md, section 1). Paper structure: held-out gap " << c["paper"]["heldout_gap_deg"].get<double>()
      << " deg alone, " << c["paper"]["final_gap_deg"].get<double>() << " deg with its " << c["paper"]["steps"].get<std::size_t>()
      << " effect(s).";
    if (c.contains("dynamic")) {
      const json& d = c["dynamic"];
      o << " Dynamic model: " << d["heldout_gap_deg"].get<double>() << " deg alone";
      if (d.contains("final_gap_deg"))
        o << ", " << d["final_gap_deg"].get<double>() << " deg with its " << d["steps"].get<std::size_t>() << " effect(s)";
      else
        o << " (not searched from: " << d.value("not_searched", "") << ")";
      o << ".";
    }
    if (c.contains("why")) {
      std::string why = c["why"].get<std::string>();
      if (!why.empty()) why[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(why[0])));
      o << " " << why << ".";
    }
  }
  o << "\n\n**Baseline residual:** " << r.baseline["where"].get<std::string>() << "\n\n";
  for (const Step& s : r.in_baseline)
    o << "**In the baseline: " << s.effect << "**: " << s.where << "; its held-out error " << s.evidence["reduction_pct"].get<double>()
      << " % below the best structure without it.\n\n";
  i = 1;
  for (const Step& s : r.steps) {
    o << "## Step " << i++ << ": " << s.effect << "\n\n- where: " << s.where << "\n- held-out gap "
      << s.evidence["heldout_gap_before_deg"].get<double>() << " -> " << s.gap_deg << " deg ("
      << s.evidence["reduction_pct"].get<double>() << " %), delta BIC " << s.evidence["delta_bic"].get<double>()
      << ", runner-up " << s.evidence["runner_up"].get<std::string>() << "\n";
    if (s.evidence.contains("dynamic_rate_gain_s_per_rad")) {
      const json& g = s.evidence["dynamic_rate_gain_s_per_rad"];
      const double before = g["before"].get<double>(), after = g["after"].get<double>();
      if (after != before)
        o << "- the dynamic model's rate gain, chosen again with this effect in: " << before << " -> " << after << " s/rad\n";
    }
    o << "\n";
  }
  if (r.compensated.contains("error"))
    o << "## The angle the compensator outputs\n\n" << r.compensated["error"].get<std::string>()
      << "; model.toml holds the baseline.\n\n";
  if (r.compensated.contains("rmse_before_deg")) {
    const json& c = r.compensated;
    o << "## The angle the compensator outputs\n\n"
      << "On held-out blocks, `pof compensate`'s angle against the reference: RMSE " << c["rmse_before_deg"].get<double>()
      << " deg with the baseline, " << c["rmse_after_deg"].get<double>() << " deg with the found model applied ("
      << c["reduction_pct"].get<double>() << " % lower)";
    if (!c["not_applied"].empty())
      o << "; not applied online and not written to model.toml (the compensator refuses them): " << c["not_applied"].dump();
    o << ".\n\n";
    for (const json& l : c["left_out_of_model"])
      o << "- **" << l["effect"].get<std::string>() << " is not written to model.toml**: applied online it made the held-out "
        << "angle worse (RMSE " << l["rmse_with_deg"].get<double>() << " deg with it, " << l["rmse_without_deg"].get<double>()
        << " deg without). It is found all the same (above).\n";
    if (!c["left_out_of_model"].empty())
      o << "\nWith the effects model.toml holds: RMSE " << c["rmse_written_deg"].get<double>()
        << " deg (chosen on these blocks, so optimistic).\n";
    if (c.contains("model_toml_nested"))
      o << "\nWhat model.toml gives, each block scored with the choice (effects kept, or the baseline) made on the "
           "other blocks alone: RMSE " << c["model_toml_nested"]["rmse_deg"].get<double>() << " deg ("
        << c["model_toml_nested"]["reduction_pct"].get<double>() << " % lower than the baseline).\n";
    if (r.angle_vs_forward.contains("summary"))
      o << "\nAgainst the forward gap (docs/gap.md, section 5, \"Angle against the forward gap\"): "
        << r.angle_vs_forward["summary"].get<std::string>() << "\n";
    if (const std::string held = c.value("model_toml", ""); held != "found model")
      o << "\n**model.toml holds the " << held << "**.\n";
    o << "\n![compensated angle](compensated.png)\n\n";
  }
  if (!r.indistinguishable.empty()) {
    o << "## Indistinguishable on this recording\n\n";
    for (const json& d : r.indistinguishable) {
      std::string names;
      for (const json& e : d["effects"]) names += (names.empty() ? "" : " or ") + e.get<std::string>();
      o << "- **" << names << "**: " << d["what"].get<std::string>() << ".";
      if (const std::string t = d.value("tells_apart", ""); !t.empty())
        o << " What would tell them apart: " << t << ".";
      o << " model.toml: " << d["taken"].get<std::string>() << ".\n";
    }
    o << "\n";
  }
  o << "## What is left\n\n" << (r.unexplained ? "Structure remains that no candidate explains" : "No significant structure left")
    << ": residual RMS / scan-to-scan noise floor = " << r.whiteness["rms_over_noise_floor"].get<double>()
    << ", Ljung-Box Q(20) = " << r.whiteness["ljung_box_q20"].get<double>() << " (5 % critical 31.41).\n"
    << "Final residual: " << r.whiteness["final_where"].get<std::string>() << "\n\n"
    << "![residual against time](residual_time.png)\n![residual against angle](residual_angle.png)\n"
    << "![residual against velocity](residual_velocity.png)\n![loops](loops.png)\n![gap per step](gap_steps.png)\n";
  return o.str();
}

}  // namespace

void write_outputs(const Result& r, const std::string& source, const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) throw pof::IoError(dir.string() + ": cannot create the output directory: " + ec.message());
  json j = r.to_json();
  j["source"] = source;
  io::write_file_atomic(dir / "gap.json", j.dump(2) + "\n");
  // The model is written once the compensator has checked it (the last stage).
  if (r.complete()) io::write_file_atomic(dir / "model.toml", model_toml(r, source));
  std::string csv =
      "t_s,angle_deg,w_rad_s,v,model_baseline_v,model_final_v,resid_baseline_deg,resid_final_deg,angle_comp_before_deg,"
      "angle_comp_after_deg\n";
  char buf[256];
  const Series& s = r.series;
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    const int n = std::snprintf(buf, sizeof buf, "%.4f,%.4f,%.5f,%.6f,%.6f,%.6f,%.5f,%.5f,%.5f,%.5f\n", s.t[i], s.angle[i], s.w[i],
                                s.v[i], s.model_baseline[i], s.model_final[i], s.resid_baseline_deg[i], s.resid_final_deg[i],
                                s.angle_comp_before[i], s.angle_comp_after[i]);
    csv.append(buf, static_cast<std::size_t>(n));
  }
  io::write_file_atomic(dir / "series.csv", csv);
  io::write_file_atomic(dir / "report.md", report_md(r, source));
}

}  // namespace pof::gap
