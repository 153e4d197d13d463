// `pof compensate <recording> --cal cal.toml [--csv out.csv] [--json stats.json]`: applies a
// calibration offline through the online path (pof::core::compensate_recording: the daemon's
// OnlineCompensator and CycleStatistics, scan by scan) and prints the table-3 statistics.
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>

#include "commands.hpp"
#include "compensation_csv.hpp"
#include "pof/core/offline.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/io/calibration_file.hpp"
#include "pof/base/errors.hpp"
#include "pof/io/recording_reader.hpp"
#include "pof/io/report_json.hpp"
#include "progress.hpp"

namespace pof::cli {

namespace {

struct CompensateOptions {
  std::string recording, cal, csv, json, pot_cal, channel;
  std::string velocity_source = "sensor";
  std::string model = "file";
  double window_s = 0.5;
  double reversal_window_s = pof::core::CompensatorSettings{}.reversal_window_s;
  bool no_model_steps = false;
  std::string dynamic_angle = "estimate";
  double estimator_lag_ms = 0;
};

// Table 3's columns, units in the header (degrees, percent of the span, rad/s).
void print_table(std::FILE* out, const pof::core::OfflineResult& r) {
  std::fprintf(out, "%-7s %9s %11s %13s %8s %10s %11s\n", "cycle", "w [rad/s]", "RMSE [deg]", "uncomp [deg]", "H [%]",
               "uncomp [%]", "max [deg]");
  auto row = [out](const char* label, const pof::core::CycleStats& c) {
    std::fprintf(out, "%-7s %9.4f %11.3f %13.3f %8.2f %10.2f %11.3f\n", label, c.velocity_rad_s, c.rmse_comp_deg,
                 c.rmse_uncomp_deg, c.hysteresis_comp_pct, c.hysteresis_uncomp_pct, c.max_error_deg);
  };
  for (const auto& c : r.cycles) row(std::to_string(c.cycle).c_str(), c);
  if (r.cycles.empty()) std::fprintf(out, "(no complete flexion/extension cycle in the recording)\n");
  else row("overall", r.overall);
}

void run(const CompensateOptions& o) {
  if (o.reversal_window_s > o.window_s)
    throw CLI::ValidationError("--reversal-window", "must not exceed --velocity-window (" + std::to_string(o.window_s) + " s)");
  pof::io::refuse_output_over_input({{"recording", o.recording}, {"--cal", o.cal}, {"--pot-cal", o.pot_cal}},
                                    {{"--csv", o.csv}, {"--json", o.json}});
  Progress progress("compensate");
  progress.stage("reading " + o.cal);
  const pof::io::CalibrationFile cal = pof::io::load_calibration(o.cal, o.model);
  std::optional<pof::core::PotentiometerCalibration> pot = cal.potentiometer;
  if (!o.pot_cal.empty()) pot = pof::io::load_potentiometer(o.pot_cal);
  progress.stage("reading " + o.recording);
  const pof::io::Recording rec = pof::io::read_recording(o.recording, o.channel);
  // The [gap] checks that need the scan rate (a notch below Nyquist), at the recording's.
  pof::io::require_applicable_gap(cal, o.cal, pof::core::median_rate_hz(rec.t_s));
  Eigen::VectorXd ref;
  try {
    ref = pof::io::reference_angle(rec, pot ? &*pot : nullptr);
  } catch (const pof::DataError&) {
    if (o.velocity_source == "reference") throw;
  }
  pof::core::CompensatorSettings s;
  s.velocity_window_s = o.window_s;
  s.reversal_window_s = o.reversal_window_s;
  s.model_steps = !o.no_model_steps;
  s.estimate = o.dynamic_angle == "estimate";
  s.estimator_lag_s = o.estimator_lag_ms / 1000;
  s.velocity_source = o.velocity_source == "reference" ? pof::core::VelocitySource::kReference : pof::core::VelocitySource::kSensor;
  const auto r = pof::core::compensate_recording(rec.t_s, rec.sensor_v, rec.reference_v, ref, cal.cal, s, {},
                                                 [&](Eigen::Index i, Eigen::Index n) { progress.fraction(i, n); });
  progress.done();
  if (!o.csv.empty()) pof::io::write_output(o.csv, compensation_csv(rec.t_s, ref, r));
  if (!o.json.empty())
    pof::io::write_output(o.json, pof::io::dump(pof::io::statistics_report(r.cycles, r.overall, r.profile)));
  long flagged = 0;
  for (const auto q : r.quality) flagged += q != 0 ? 1 : 0;
  // With an output on standard output the summary goes to stderr, so the output stays parseable.
  std::FILE* const summary = o.csv == "-" || o.json == "-" ? stderr : stdout;
  std::fprintf(summary, "%s: %ld scans at %.1f Hz, calibration %s (sensor '%s', %s model), velocity from the %s; %ld scans flagged, %d gap reset(s), %d partial cycle(s) dropped\n",
              rec.source.c_str(), static_cast<long>(rec.size()), r.scan_rate_hz, o.cal.c_str(), cal.sensor_id.c_str(), pof::io::to_string(cal.cal.active),
              o.velocity_source == "reference" ? "reference angle" : "sensor angle", flagged, r.resets, r.cycles_dropped);
  print_table(summary, r);
}

}  // namespace

void add_compensate(CLI::App& app) {
  auto o = std::make_shared<CompensateOptions>();
  auto* cmd = app.add_subcommand("compensate", "Apply a calibration to a recording (offline, the daemon's code path) and print table-3 statistics");
  cmd->add_option("recording", o->recording, "Recording: CSV (t_s,sensor_v,reference_v,angle_ref_deg|pot_v) or LCM log of POF_RAW")->required();
  cmd->add_option("--cal", o->cal, "Calibration file written by `pof calibrate`")->required();
  cmd->add_option("--csv", o->csv, "Write t_s,angle_deg,angle_uncomp_deg,angle_ref_deg,velocity_rad_s,phase,quality per scan ('-' for stdout)");
  cmd->add_option("--json", o->json, "Write the per-cycle and overall statistics as JSON ('-' for stdout)");
  cmd->add_option("--pot-cal", o->pot_cal, "TOML with a [potentiometer] section, for recordings with pot_v only");
  cmd->add_option("--channel", o->channel, "LCM channel of the raw blocks (default: the first POF_RAW*)");
  cmd->add_option("--model", o->model, "Sensor model: file (the calibration's active_model), paper or dynamic")
      ->check(CLI::IsMember({"file", "paper", "dynamic"}))->capture_default_str();
  cmd->add_option("--velocity-source", o->velocity_source, "Where velocity and direction come from")
      ->check(CLI::IsMember({"sensor", "reference"}))->capture_default_str();
  cmd->add_option("--velocity-window", o->window_s, "Velocity estimator window [s]")->check(CLI::Range(0.02, 10.0))->capture_default_str();
  cmd->add_option("--reversal-window", o->reversal_window_s,
                  "Short window that detects reversals early [s] (0: direction from the velocity window alone)")
      ->check(CLI::Range(0.0, 10.0))->capture_default_str();
  cmd->add_flag("--no-model-steps", o->no_model_steps,
                "Paper model: do not read the start/stop/reversal steps eqs. (11)/(12) predict as changes of direction");
  cmd->add_option("--dynamic-angle", o->dynamic_angle,
                  "Dynamic model: estimate the angle (the calibration's [estimator]) or invert the model scan by scan")
      ->check(CLI::IsMember({"estimate", "invert"}))->capture_default_str();
  cmd->add_option("--estimator-lag", o->estimator_lag_ms,
                  "Estimator: publish each scan this late, its angle smoothed by the scans since [ms] (0: causal; "
                  "at most 256 scans; not with [gap] terms)")
      ->check(CLI::Range(0.0, 320.0))->capture_default_str();
  cmd->callback([o] { run(*o); });
}

}  // namespace pof::cli
