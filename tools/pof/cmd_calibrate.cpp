// `pof calibrate <recording> -o cal.toml [--report dir] [--model paper|dynamic]`: fits the model
// chain of Leal-Junior et al. 2017 (table 2, f1..f5) and the dynamic model (dynamic_model.hpp) to a
// recording of the calibration protocol (quasi-static steps + constant-velocity cycles), scores
// both on held-out blocks (model_selection.hpp), marks the better one active, writes the
// calibration file and, with --report, a JSON with every figure and PNG plots
// (tools/plot/calibration_report.py).
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

#include "commands.hpp"
#include "plot.hpp"
#include "compensation_csv.hpp"
#include "pof/core/calibration.hpp"
#include "pof/core/dynamic_fit.hpp"
#include "pof/core/model_selection.hpp"
#include "pof/core/normalise.hpp"
#include "pof/core/offline.hpp"
#include "pof/core/units.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/io/calibration_file.hpp"
#include "pof/base/errors.hpp"
#include "pof/io/recording_reader.hpp"
#include "pof/io/report_json.hpp"
#include "pof/service/cli_checks.hpp"
#include "progress.hpp"

namespace pof::cli {

namespace {

struct CalibrateOptions {
  std::string recording, output, report, pot_cal, channel, sensor_id;
  std::string model = "auto";  // auto: the lower held-out error
  double min_hold_s = 3.0, min_sweep_deg = 20.0;
  bool no_plots = false;
};

// Per-scan series of the dynamic model for the report's plots: the fitted forward model against
// the measured voltage, and both models' held-out angles.
std::string dynamic_csv(const Eigen::VectorXd& t, const Eigen::VectorXd& ref, const Eigen::VectorXd& v,
                        const Eigen::VectorXd& v_model, const pof::core::ModelComparison& c) {
  std::string out = "t_s,angle_ref_deg,v_meas,v_dynamic,heldout_paper_deg,heldout_dynamic_deg\n";
  char buf[256];
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%.6f,%.5f,%.6f,%.6f,%.5f,%.5f\n", t(i), ref(i), v(i), v_model(i), c.paper_deg(i),
                  c.dynamic_deg(i));
    out += buf;
  }
  return out;
}

std::string utc_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// Plots are a convenience on top of the complete JSON report: a plotting failure warns, not fails.
bool run_plots(const std::string& dir) {
  try {
    run_plot_script("calibration_report.py", {dir});
    return true;
  } catch (const pof::IoError& e) {
    std::fprintf(stderr, "pof calibrate: warning: %s; the JSON report is complete, the plots are not\n", e.what());
    return false;
  }
}

void run(const CalibrateOptions& o) {
  std::vector<pof::io::NamedPath> outputs = {{"-o", o.output}};
  if (!o.report.empty())
    for (const char* f : {"calibration.json", "compensated.csv", "dynamic.csv"})
      outputs.push_back({"--report", std::filesystem::path(o.report) / f});
  pof::io::refuse_output_over_input({{"recording", o.recording}, {"--pot-cal", o.pot_cal}}, outputs);
  Progress progress("calibrate");
  std::optional<pof::core::PotentiometerCalibration> pot;
  if (!o.pot_cal.empty()) pot = pof::io::load_potentiometer(o.pot_cal);
  progress.stage("reading " + o.recording);
  const pof::io::Recording rec = pof::io::read_recording(o.recording, o.channel);
  const Eigen::VectorXd ref = pof::io::reference_angle(rec, pot ? &*pot : nullptr);
  progress.stage("fitting f1..f5");
  pof::core::CalibrationSettings s;
  s.min_hold_s = o.min_hold_s;
  s.min_dynamic_sweep_deg = o.min_sweep_deg;
  pof::core::CalibrationResult r;
  try {
    r = pof::core::calibrate(rec.t_s, rec.sensor_v, rec.reference_v, ref, s);
  } catch (const pof::core::CalibrationError& e) {
    throw pof::DataError(rec.source + ": " + e.what());
  }
  pof::io::CalibrationFile f = pof::io::make_calibration_file(
      r, o.sensor_id, std::filesystem::path(o.recording).filename().string(), utc_now());
  f.potentiometer = pot;

  // The dynamic model from the same recording, and both models scored on held-out blocks. A
  // recording the dynamic fit cannot use leaves the paper model active and says why.
  progress.stage("fitting the dynamic model");
  pof::core::ReferenceGuard guard;
  guard.level_v = r.cal.reference_level_v;
  const Eigen::VectorXd v = pof::core::normalise(rec.sensor_v, rec.reference_v, guard);
  std::optional<pof::core::DynamicFitResult> dyn;
  std::optional<pof::core::ModelComparison> cmp;
  std::string estimator_note;
  try {
    dyn = pof::core::fit_dynamic(rec.t_s, v, ref);
    progress.stage("held-out comparison of both models");
    cmp = pof::core::compare_held_out(rec.t_s, rec.sensor_v, rec.reference_v, ref, *dyn, s);
  } catch (const pof::core::DynamicFitError& e) {
    f.dynamic_note = std::string("no dynamic model: ") + e.what();
    if (o.model == "dynamic") throw pof::DataError(rec.source + ": --model dynamic: " + e.what());
  }
  if (dyn) {
    f.cal.dynamic = dyn->model;
    f.dynamic_fit_note = pof::io::dynamic_fit_note(*dyn);
    // The estimator's noises; without them the dynamic model's angle is inverted scan by scan.
    f.cal.estimator = dyn->estimator;
    if (!dyn->estimator) estimator_note = "no [estimator], the dynamic model is inverted scan by scan: " + dyn->estimator_note;
    if (cmp && cmp->folds_used > 0) {
      f.held_out = pof::io::HeldOutSummary{cmp->paper.rmse_deg, cmp->paper.p99_abs_deg, cmp->dynamic.rmse_deg,
                                           cmp->dynamic.p99_abs_deg, cmp->folds_used};
      if (cmp->dynamic.rmse_deg < cmp->paper.rmse_deg) f.cal.active = pof::core::ModelKind::kDynamic;
      else f.dynamic_note = "the dynamic model is not active: its held-out error is not lower than the paper model's";
    } else {
      f.dynamic_note = "the dynamic model is not active: no held-out block could be scored for both models";
    }
  }
  if (o.model != "auto") {
    f.cal.active = *pof::io::model_kind_of(o.model);  // CLI11 admits auto, paper and dynamic only
    f.dynamic_note = "active model chosen with --model " + o.model;
  }
  // Validate what we are about to write with the loader's own rules: a fit that the loader would
  // refuse must fail here, not later in the daemon.
  const std::string kept_note = f.dynamic_note, kept_fit_note = f.dynamic_fit_note;  // comments: not read back
  f = pof::io::parse_calibration(pof::io::to_toml(f), o.output + " (about to be written)");
  f.dynamic_note = kept_note;
  f.dynamic_fit_note = kept_fit_note;
  pof::io::save_calibration(f, o.output);

  const auto& q = r.quasi_static;
  std::printf("%s: %ld scans, %zu holds, %zu velocity tests (%.4f-%.4f rad/s), reference level %.4f V\n",
              rec.source.c_str(), static_cast<long>(rec.size()), static_cast<std::size_t>(q.hold_v.size()), r.tests.size(),
              r.cal.velocity_min_rad_s, r.cal.velocity_max_rad_s, r.cal.reference_level_v);
  std::printf("f5  alpha = %.4f V2 + %.3f   sensitivity %.4f V/deg, linearity R^2 %.5f\n", -r.cal.model.c9,
              r.cal.model.c10, std::abs(q.v_of_angle.slope), q.v_of_angle.r2);
  std::printf("f1  h = %.4g exp(%.4g w)   (SE %.2g, %.2g; R^2 %.4f)\n", r.f1.c1, r.f1.c2, r.f1.c1_se, r.f1.c2_se, r.f1.r2);
  std::printf("eq. (11)  %s\n", f.equation_flexion.c_str());
  std::printf("eq. (12)  %s\n", f.equation_extension.c_str());
  if (dyn) {
    const auto& m = dyn->model;
    std::printf("dynamic   degree %d, %d stop operators (%.3g-%.3g deg, loop +-%.4f V), rate gain %+.3g s/rad, %d Prony term(s), "
                "bend lag %.3g s; train RMSE %.3f deg, CV %.3f deg over %zu structures\n",
                m.degree, m.n_operators, m.n_operators ? m.threshold_deg[0] : 0.0,
                m.n_operators ? m.threshold_deg[static_cast<std::size_t>(m.n_operators - 1)] : 0.0, m.loop_half_height_v(),
                m.rate_gain_s_per_rad, m.n_prony, m.bend_lag_s, dyn->train_rmse_deg, dyn->chosen.cv_rmse_deg, dyn->candidates.size());
    if (!f.dynamic_fit_note.empty()) std::printf("          %s\n", f.dynamic_fit_note.c_str());
    // What the recording cannot tell: the loop's rate dependence beyond its fastest motion
    // (docs/calibration.md, "Speeds beyond the calibration": gait after a slow-only protocol).
    std::printf("speeds    identified up to %.2f rad/s (%.0f deg/s); faster, the loop keeps its shape at that speed and "
                "the angle carries QUALITY_VELOCITY_EXTRAPOLATED: to compensate gait (2 rad/s and more), record some in the "
                "calibration\n", m.speed_limit_rad_s, m.speed_limit_rad_s * pof::core::kDegPerRad);
    if (f.cal.estimator)
      std::printf("estimator voltage noise %.3g mV (holds), acceleration noise %.0f deg/s^2\n",
                  1e3 * f.cal.estimator->voltage_noise_v, f.cal.estimator->acceleration_noise_deg_s2);
    else
      std::printf("estimator %s\n", estimator_note.c_str());
  }
  if (f.held_out)
    std::printf("held-out  (%lld blocks) paper RMSE %.3f deg (p99 %.3f), dynamic RMSE %.3f deg (p99 %.3f)\n",
                static_cast<long long>(f.held_out->folds), f.held_out->paper_rmse_deg, f.held_out->paper_p99_deg,
                f.held_out->dynamic_rmse_deg, f.held_out->dynamic_p99_deg);
  if (cmp)
    for (const auto& note : cmp->notes) std::printf("          note: %s\n", note.c_str());
  std::printf("active    %s%s%s\n", pof::io::to_string(f.cal.active), f.dynamic_note.empty() ? "" : " (",
              f.dynamic_note.empty() ? "" : (f.dynamic_note + ")").c_str());
  std::printf("wrote %s\n", o.output.c_str());

  if (!o.report.empty()) {
    progress.stage("report");
    std::error_code ec;
    std::filesystem::create_directories(o.report, ec);
    if (ec) throw pof::IoError(o.report + ": cannot create the report directory: " + ec.message());
    // The calibration applied to its own recording: loops before/after and error against angle.
    const auto self = pof::core::compensate_recording(rec.t_s, rec.sensor_v, rec.reference_v, ref, r.cal);
    nlohmann::json j = pof::io::calibration_report(r);
    j["source_recording"] = rec.source;
    j["date"] = f.date;
    j["self_check"] = pof::io::statistics_report(self.cycles, self.overall, self.profile);
    j["active_model"] = pof::io::to_string(f.cal.active);
    if (dyn) j["dynamic"] = pof::io::dynamic_report(*dyn, cmp ? &*cmp : nullptr);
    if (f.cal.estimator)
      j["estimator"] = {{"voltage_noise_v", f.cal.estimator->voltage_noise_v},
                        {"acceleration_noise_deg_s2", f.cal.estimator->acceleration_noise_deg_s2}};
    else if (dyn)
      j["estimator"] = {{"error", estimator_note}};
    else j["dynamic"] = {{"error", f.dynamic_note}};
    if (dyn && cmp) {
      const Eigen::VectorXd vm = pof::core::forward_dynamic(dyn->model, ref, pof::core::median_rate_hz(rec.t_s));
      pof::io::write_file_atomic(o.report + "/dynamic.csv", dynamic_csv(rec.t_s, ref, v, vm, *cmp));
    }
    pof::io::write_file_atomic(o.report + "/calibration.json", pof::io::dump(j));
    pof::io::write_file_atomic(o.report + "/compensated.csv", compensation_csv(rec.t_s, ref, self));
    progress.stage("plots");
    const bool plotted = !o.no_plots && run_plots(o.report);
    progress.done();
    std::printf("report in %s (calibration.json, compensated.csv%s)\n", o.report.c_str(),
                plotted ? ", fig6_quasi_static.png, fig7_regressions.png, loops.png, error_vs_angle.png" : "");
  }
}

}  // namespace

void add_calibrate(CLI::App& app) {
  auto o = std::make_shared<CalibrateOptions>();
  auto* cmd = app.add_subcommand("calibrate", "Fit the hysteresis-compensation model (table 2, f1..f5) to a calibration recording");
  cmd->add_option("recording", o->recording, "Recording: CSV (t_s,sensor_v,reference_v,angle_ref_deg|pot_v) or LCM log of POF_RAW")->required();
  cmd->add_option("-o,--output", o->output, "Calibration file to write (TOML)")->required();
  cmd->add_option("--report", o->report, "Directory for calibration.json, compensated.csv and PNG plots");
  cmd->add_option("--pot-cal", o->pot_cal, "TOML with a [potentiometer] section, for recordings with pot_v only");
  cmd->add_option("--channel", o->channel, "LCM channel of the raw blocks (default: the first POF_RAW*)");
  cmd->add_option("--sensor-id", o->sensor_id, "Sensor/joint identifier stored in the file, e.g. LEFT_KNEE")
      ->check(pof::service::sensor_id());
  cmd->add_option("--min-hold", o->min_hold_s, "Shortest hold [s] used by the quasi-static fit")->check(CLI::Range(0.5, 600.0))->capture_default_str();
  cmd->add_option("--min-sweep", o->min_sweep_deg, "Smallest sweep [deg] counted as a dynamic test")->check(CLI::Range(2.0, 180.0))->capture_default_str();
  cmd->add_option("--model", o->model, "Model marked active: auto (the lower held-out error), paper or dynamic")
      ->check(CLI::IsMember({"auto", "paper", "dynamic"}))->capture_default_str();
  cmd->add_flag("--no-plots", o->no_plots, "Write the JSON report only");
  cmd->callback([o] { run(*o); });
}

}  // namespace pof::cli
