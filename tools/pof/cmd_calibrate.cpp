// `pof calibrate <recording> -o cal.toml [--report dir]`: fits the model chain of Leal-Junior et
// al. 2017 (table 2, f1..f5) to a recording of the calibration protocol (quasi-static steps +
// constant-velocity cycles), writes the calibration file and, with --report, a JSON with every
// figure and PNG plots (tools/plot/calibration_report.py).
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

#include "commands.hpp"
#include "plot.hpp"
#include "compensation_csv.hpp"
#include "pof/core/calibration.hpp"
#include "pof/core/offline.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/io/calibration_file.hpp"
#include "pof/io/errors.hpp"
#include "pof/io/recording_reader.hpp"
#include "pof/io/report_json.hpp"
#include "progress.hpp"

namespace pof::cli {

namespace {

struct CalibrateOptions {
  std::string recording, output, report, pot_cal, channel, sensor_id;
  double min_hold_s = 3.0, min_sweep_deg = 20.0;
  bool no_plots = false;
};

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
  } catch (const pof::io::IoError& e) {
    std::fprintf(stderr, "pof calibrate: warning: %s; the JSON report is complete, the plots are not\n", e.what());
    return false;
  }
}

void run(const CalibrateOptions& o) {
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
    throw pof::io::DataError(rec.source + ": " + e.what());
  }
  pof::io::CalibrationFile f = pof::io::make_calibration_file(
      r, o.sensor_id, std::filesystem::path(o.recording).filename().string(), utc_now());
  f.potentiometer = pot;
  // Validate what we are about to write with the loader's own rules: a fit that the loader would
  // refuse must fail here, not later in the daemon.
  f = pof::io::parse_calibration(pof::io::to_toml(f), o.output + " (about to be written)");
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
  std::printf("wrote %s\n", o.output.c_str());

  if (!o.report.empty()) {
    progress.stage("report");
    std::error_code ec;
    std::filesystem::create_directories(o.report, ec);
    if (ec) throw pof::io::IoError(o.report + ": cannot create the report directory: " + ec.message());
    // The calibration applied to its own recording: loops before/after and error against angle.
    const auto self = pof::core::compensate_recording(rec.t_s, rec.sensor_v, rec.reference_v, ref, r.cal);
    nlohmann::json j = pof::io::calibration_report(r);
    j["source_recording"] = rec.source;
    j["date"] = f.date;
    j["self_check"] = pof::io::statistics_report(self.cycles, self.overall, self.profile);
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
  cmd->add_option("--sensor-id", o->sensor_id, "Sensor/joint identifier stored in the file, e.g. LEFT_KNEE");
  cmd->add_option("--min-hold", o->min_hold_s, "Shortest hold [s] used by the quasi-static fit")->check(CLI::Range(0.5, 600.0))->capture_default_str();
  cmd->add_option("--min-sweep", o->min_sweep_deg, "Smallest sweep [deg] counted as a dynamic test")->check(CLI::Range(2.0, 180.0))->capture_default_str();
  cmd->add_flag("--no-plots", o->no_plots, "Write the JSON report only");
  cmd->callback([o] { run(*o); });
}

}  // namespace pof::cli
