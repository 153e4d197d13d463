// Files of `pof gap` (see io.hpp).
#include "pof/gap/io.hpp"

#include <charconv>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <system_error>
#include <vector>


#include "pof/io/atomic_file.hpp"
#include "pof/base/errors.hpp"

namespace pof::gap {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string num(double x) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", x);
  return b;
}

std::string quoted(const std::string& x) {
  std::string o = "\"";
  for (char c : x) {
    if (c == '"' || c == '\\') o += '\\';
    o += c;
  }
  return o + "\"";
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return b;
}

// The calibration-file layout of `pof calibrate` (docs/calibration.md, schema_version 1), so
// `pof compensate --cal model.toml` reads the refitted model; the accepted effects go in [gap],
// which that loader (strict about every other key) skips by name (docs/gap.md).
std::string model_toml(const Result& r, const std::string& source) {
  const json& m = r.model;
  std::ostringstream o;
  o << "# Improved sensor model written by `pof gap` (docs/gap.md). The calibration-file layout of\n"
       "# `pof calibrate` (docs/calibration.md): the paper's structure with its coefficients fitted to the\n"
       "# recording; [gap] holds the accepted effect terms, added to the model voltage.\n"
    << "schema_version = 1\n"
    << "sensor_id = \"pof-gap\"\n"
    << "date = " << quoted(utc_now()) << "\n"
    << "source_recording = " << quoted(source) << "\n"
    << "reference_level_v = " << num(m["reference_level_v"].get<double>()) << "    # the level c1..c10 apply at\n"
    << "\n[model]\n"
    << "c1 = " << num(m["c1"].get<double>()) << "\n"
    << "c2 = " << num(m["c2"].get<double>()) << "\n"
    << "c9 = " << num(m["c9"].get<double>()) << "\n"
    << "c10 = " << num(m["c10"].get<double>()) << "\n";
  for (const char* d : {"flexion", "extension"}) {
    const auto& v = m[d];
    o << "\n[model." << d << "]\n";
    for (int i = 0; i < 6; ++i) o << "c" << i + 3 << " = " << num(v[static_cast<std::size_t>(i)].get<double>()) << "\n";
  }
  const auto& rg = m["range"];
  o << "\n[range]\n"
    << "angle_min_deg = " << num(rg["angle_min_deg"].get<double>()) << "\n"
    << "angle_max_deg = " << num(rg["angle_max_deg"].get<double>()) << "\n"
    << "velocity_min_rad_s = " << num(rg["velocity_min_rad_s"].get<double>()) << "\n"
    << "velocity_max_rad_s = " << num(rg["velocity_max_rad_s"].get<double>()) << "\n"
    << "\n[fit_quality]    # `pof gap` fits the voltage, not f1-f4 one by one: their R^2 / RMSE are given as -1\n"
    << "sensitivity_v_per_deg = " << num(1.0 / m["c9"].get<double>()) << "\n"
    << "linearity_r2 = " << num(m["linearity_r2"].get<double>()) << "\n"
    << "f1_r2 = -1\nf1_rmse_pct = -1\nf4_flexion_r2 = -1\nf4_extension_r2 = -1\n"
    << "n_holds = " << m["n_holds"].get<long long>() << "\n"
    << "n_velocity_tests = 0\n"
    << "\n[equations]    # informational\n"
    << "flexion = \"paper eq. (11), coefficients refitted by pof gap\"\nextension = \"paper eq. (12), coefficients refitted by pof gap\"\n"
    << "\n[gap]    # `pof gap` extension: v_model += sum of the terms (docs/gap.md)\n"
    << "source = " << quoted(source) << "\n"
    << "baseline_gap_deg = " << num(r.baseline_gap_deg) << "\n"
    << "final_gap_deg = " << num(r.final_gap_deg) << "\n"
    << "delay_s = " << num(m["delay_s"].get<double>()) << "    # sensor lags the reference angle by this\n"
    << "backlash_deg = " << num(m["backlash_deg"].get<double>()) << "    # belt dead band between joint and potentiometer\n"
    << "duration_s = " << num(m["duration_s"].get<double>()) << "    # drift is linear in t / duration_s - 1/2\n";
  for (const auto& term : m["terms"]) {
    o << "\n[[gap.terms]]\neffect = " << quoted(term["effect"].get<std::string>()) << "\n"
      << "theta = " << num(term["theta"].get<double>()) << "\n";
    for (const char* key : {"thresholds_deg", "time_constants_s"}) {
      if (!term.contains(key)) continue;
      o << key << " = [";
      bool first = true;
      for (const auto& c : term[key]) {
        o << (first ? "" : ", ") << num(c.get<double>());
        first = false;
      }
      o << "]\n";
    }
    o
      << "coefficients_v = [";
    bool first = true;
    for (const auto& c : term["coefficients_v"]) {
      o << (first ? "" : ", ") << num(c.get<double>());
      first = false;
    }
    o << "]\n";
    o << "[gap.terms.parameters]\n";
    for (auto it = term["parameters"].begin(); it != term["parameters"].end(); ++it)
      o << it.key() << " = " << num(it.value().get<double>()) << "\n";
  }
  return o.str();
}

std::string report_md(const Result& r, const std::string& source) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(3);
  o << "# Model gap report: " << source << "\n\n"
    << "Held-out RMS residual (time-blocked " << r.recording["folds"].get<std::size_t>() << "-fold CV) in degrees.\n\n"
    << "| step | effect | held-out gap [deg] | parameters |\n|---|---|---|---|\n"
    << "| 0 | baseline (paper structure, coefficients fitted to the recording) | " << r.baseline_gap_deg << " | c9 = "
    << r.baseline["c9_deg_per_v"].get<double>() << " deg/V, c10 = " << r.baseline["c10_deg"].get<double>() << " deg |\n";
  int i = 1;
  for (const Step& s : r.steps) o << "| " << i++ << " | " << s.effect << " | " << s.gap_deg << " | `" << s.parameters.dump() << "` |\n";
  o << "\n**Baseline residual:** " << r.baseline["where"].get<std::string>() << "\n\n";
  i = 1;
  for (const Step& s : r.steps) {
    o << "## Step " << i++ << ": " << s.effect << "\n\n- where: " << s.where << "\n- held-out gap "
      << s.evidence["heldout_gap_before_deg"].get<double>() << " -> " << s.gap_deg << " deg ("
      << s.evidence["reduction_pct"].get<double>() << " %), delta BIC " << s.evidence["delta_bic"].get<double>()
      << ", runner-up " << s.evidence["runner_up"].get<std::string>() << "\n\n";
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
  io::write_file_atomic(dir / "model.toml", model_toml(r, source));
  std::string csv = "t_s,angle_deg,w_rad_s,v,model_baseline_v,model_final_v,resid_baseline_deg,resid_final_deg\n";
  char buf[256];
  const Series& s = r.series;
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    const int n = std::snprintf(buf, sizeof buf, "%.4f,%.4f,%.5f,%.6f,%.6f,%.6f,%.5f,%.5f\n", s.t[i], s.angle[i], s.w[i], s.v[i],
                                s.model_baseline[i], s.model_final[i], s.resid_baseline_deg[i], s.resid_final_deg[i]);
    csv.append(buf, static_cast<std::size_t>(n));
  }
  io::write_file_atomic(dir / "series.csv", csv);
  io::write_file_atomic(dir / "report.md", report_md(r, source));
}

}  // namespace pof::gap
