// `pof sim <scenario|builtin> -o out.{lcmlog,csv}`: run the physics simulator (daq/sim/) and
// write a recording in the formats every other tool reads, with the ground-truth angle. --plot
// draws the scenario's loops and the effect traces (tools/plot/sim_loops.py).
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "plot.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/io/csv_writer.hpp"
#include "pof/base/errors.hpp"
#include "pof/io/lcmlog_writer.hpp"
#include "pof/service/cli_checks.hpp"
#include "pof/sim/scenario.hpp"
#include "pof/sim/simulator.hpp"

namespace pof::cli {
namespace {

struct SimOptions {
  std::string scenario;
  std::string output;
  double seconds = 0;
  std::uint64_t seed = 1;
  double rate = 0;
  std::string plot;
  std::string trace;
  int block_scans = 20;
  bool pot_column = false;
};

namespace fs = std::filesystem;

pof::sim::Scenario resolve_scenario(const std::string& arg) {
  // A path that exists is a file; otherwise a builtin name; otherwise say both were tried.
  std::error_code ec;
  if (fs::exists(arg, ec)) return pof::sim::load_scenario(arg);
  const auto names = pof::sim::builtin_scenario_names();
  for (const auto& n : names)
    if (n == arg) return pof::sim::builtin_scenario(arg);
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  throw pof::NoInputError(arg + ": no such scenario file, and not a builtin scenario (" + list + ")");
}

void run_plot(const fs::path& trace_csv, const std::string& png, const std::string& title, double reference_level_v) {
  run_plot_script("sim_loops.py", {trace_csv.string(), png, "--title", title, "--reference-level", std::to_string(reference_level_v)});
}

void run_sim(const SimOptions& o) {
  std::error_code ec;
  const bool scenario_file = fs::exists(o.scenario, ec);
  pof::io::refuse_output_over_input({{"scenario", scenario_file ? o.scenario : std::string()}},
                                    {{"-o", o.output}, {"--plot", o.plot}, {"--trace", o.trace}});
  pof::sim::Scenario sc = resolve_scenario(o.scenario);
  if (o.seconds > 0) sc.duration_s = o.seconds;
  if (sc.loop && sc.duration_s <= 0)
    throw pof::ConfigError(sc.source + ": key 'loop': the scenario loops forever; give --seconds or duration_s");
  pof::sim::Simulator sim(sc, o.seed, o.rate);

  const fs::path out(o.output);
  const bool csv = out.extension() == ".csv";
  std::unique_ptr<pof::io::CsvWriter> csv_w;
  std::unique_ptr<pof::io::LcmLogWriter> lcm_w;
  if (csv) {
    pof::io::CsvColumns cols;
    cols.pot_v = o.pot_column;
    csv_w = std::make_unique<pof::io::CsvWriter>(out, cols);
  } else {
    pof::io::LcmLogOptions lo;
    lo.sensor_id = sc.sensor_id;
    lo.scan_rate_hz = sim.scan_rate_hz();
    lo.block_scans = o.block_scans;
    lcm_w = std::make_unique<pof::io::LcmLogWriter>(out, lo);
  }

  // The effect traces for --plot go to a private temporary CSV next to the PNG.
  std::FILE* trace = nullptr;
  fs::path trace_path;
  const bool keep_trace = !o.trace.empty();
  if (!o.plot.empty() || keep_trace) {
    trace_path = keep_trace ? fs::path(o.trace) : fs::path(o.plot).replace_extension(".trace.csv.tmp");
    trace = std::fopen(trace_path.c_str(), "w");
    if (trace == nullptr) throw pof::IoError(trace_path.string() + ": cannot write the plot data");
    std::fputs("t_s,sensor_v,reference_v,pot_v,angle_ref_deg,angle_true_deg,velocity_rad_s,acceleration_rad_s2,"
               "direction,quasi_static_v,static_nonlinearity_v,hysteresis_v,rate_dependent_hysteresis_v,creep_v,"
               "acceleration_v,drift_v,normalised_v,source_power_rel,pot_error_deg,memory_hysteresis_v,viscoelastic_lag_v,"
               "lag_deg,memory_state,power_law_relaxation_v,cyclic_softening_v,travel_deg\n", trace);
  }
  struct TraceCloser {
    std::FILE*& f;
    fs::path& p;
    ~TraceCloser() {
      if (f != nullptr) std::fclose(f);
      std::error_code ec;
      if (!p.empty()) fs::remove(p, ec);
    }
  } closer{trace, trace_path};
  fs::path trace_for_plot = trace_path;
  if (keep_trace) trace_path.clear();  // kept: the closer only closes it

  const auto t0 = std::chrono::steady_clock::now();
  std::vector<pof::sim::Scan> scans(4096);
  std::vector<pof::sim::EffectTrace> traces(trace != nullptr ? scans.size() : 0);
  std::int64_t n_total = 0, n_over = 0;
  for (;;) {
    const std::size_t n = sim.next(scans, traces);
    if (n == 0) break;
    for (std::size_t i = 0; i < n; ++i) {
      const auto& s = scans[i];
      pof::io::RecordingRow r{s.t_s, s.sensor_v, s.reference_v, s.pot_v, s.angle_ref_deg, s.angle_true_deg, s.over_range != 0};
      n_over += s.over_range != 0;
      if (csv_w) csv_w->write(r);
      else lcm_w->write(r);
      if (trace != nullptr) {
        const auto& e = traces[i];
        std::fprintf(trace, "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%d,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n",
                     s.t_s, s.sensor_v, s.reference_v, s.pot_v, s.angle_ref_deg, s.angle_true_deg, e.velocity_rad_s,
                     e.acceleration_rad_s2, e.direction, e.quasi_static_v, e.static_nonlinearity_v, e.hysteresis_v,
                     e.rate_dependent_hysteresis_v, e.creep_v, e.acceleration_v, e.drift_v, e.normalised_v,
                     e.source_power_rel, e.pot_error_deg, e.memory_hysteresis_v, e.viscoelastic_lag_v, e.lag_deg, e.memory_state,
                     e.power_law_relaxation_v, e.cyclic_softening_v, e.travel_deg);
      }
    }
    n_total += static_cast<std::int64_t>(n);
  }
  if (csv_w) csv_w->commit();
  else lcm_w->commit();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  spdlog::info("pof sim: scenario '{}' seed {}: {} scans ({:.1f} s of data at {} Hz) -> {}{} in {:.2f} s",
               sc.name, o.seed, n_total, static_cast<double>(n_total) / sim.scan_rate_hz(), sim.scan_rate_hz(),
               o.output, lcm_w ? " (" + std::to_string(lcm_w->blocks()) + " POF_RAW blocks)" : std::string{}, wall);
  if (n_over > 0) spdlog::warn("pof sim: {} scans clipped at the DAQ range (+-{} V)", n_over, sc.daq.range_v);
  if (trace != nullptr) {
    if (std::fclose(trace) != 0) {
      trace = nullptr;
      throw pof::IoError(trace_path.string() + ": write error");
    }
    trace = nullptr;
    if (!o.plot.empty()) {
      run_plot(trace_for_plot, o.plot, sc.name + " (seed " + std::to_string(o.seed) + ")", sc.light.reference_level_v);
      spdlog::info("pof sim: plot -> {}", o.plot);
    }
  }
}

}  // namespace

void add_sim(CLI::App& app) {
  auto opt = std::make_shared<SimOptions>();
  auto* cmd = app.add_subcommand("sim", "Simulate the exoskeleton, POF sensor and DAQ; write a recording (CSV or LCM log)");
  cmd->add_option("scenario", opt->scenario, "Scenario TOML file, or a builtin name (paper, realistic)")->required();
  cmd->add_option("-o,--output", opt->output, "Output recording: *.csv or *.lcmlog")
      ->required()
      ->check([](const std::string& p) {
        const auto ext = fs::path(p).extension();
        return ext == ".csv" || ext == ".lcmlog" ? std::string{} : std::string("expected a .csv or .lcmlog file name");
      });
  cmd->add_option("--seconds", opt->seconds, "Simulate this long [s] (default: the scenario's duration or trajectory)")
      ->check(pof::service::positive(pof::service::kMaxSeconds));
  cmd->add_option("--seed", opt->seed, "Random seed (same scenario + seed = same bytes)");
  cmd->add_option("--rate", opt->rate, "Scan rate [Hz] (default: the scenario's daq.scan_rate_hz)")->check(pof::service::positive());
  cmd->add_option("--plot", opt->plot, "Also draw the loops and effect traces to this PNG");
  cmd->add_option("--trace", opt->trace, "Also write each scan's effect contributions (EffectTrace) to this CSV");
  cmd->add_option("--block-scans", opt->block_scans, "Scans per POF_RAW block in an LCM log")->check(CLI::Range(1, 100000));
  cmd->add_flag("--pot-column", opt->pot_column, "CSV: also write the pot_v column");
  cmd->callback([opt] { run_sim(*opt); });
}

}  // namespace pof::cli
