// `pof gap <recording> --out DIR`: where the baseline model and the recording disagree,
// which physical effect is missing, and how much adding it closes the gap. Method: docs/gap.md.
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "plot.hpp"
#include "pof/gap/gap.hpp"
#include "pof/gap/io.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/io/recording_reader.hpp"
#include "pof/base/errors.hpp"

namespace pof::cli {

namespace fs = std::filesystem;

namespace {

// Plots come after the numbers are written: a plotting failure is reported, not fatal.
bool make_plots(const fs::path& dir, std::string& why) {
  try {
    run_plot_script("gap_report.py", {dir.string()});
    return true;
  } catch (const pof::IoError& e) {
    why = e.what();
    return false;
  }
}

}  // namespace

void add_gap(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "gap", "Find where the model and a recording disagree, name the missing effect, add it, show the gap shrink");
  struct Args {
    std::string input, out;
    int folds = 5, max_steps = 4;
    double min_reduction_pct = 5, block_s = gap::Options{}.block_s;
    bool no_plots = false;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("recording", a->input, "Recording: CSV t_s,sensor_v,reference_v,angle_ref_deg, or an LCM log of POF_RAW blocks")->required();
  cmd->add_option("--out,-o", a->out, "Output directory (gap.json, model.toml, report.md, PNG plots)")->required();
  cmd->add_option("--folds", a->folds, "Time-blocked cross-validation folds")->check(CLI::Range(2, 20))->capture_default_str();
  cmd->add_option("--block-seconds", a->block_s,
                  "Length of the folds' time blocks, dealt to the folds in turn [s]; 0: one contiguous block per fold")
      ->check(CLI::Range(0.0, 3600.0))->capture_default_str();
  cmd->add_option("--max-steps", a->max_steps, "Most effects to add")->check(CLI::Range(0, 9))->capture_default_str();
  cmd->add_option("--min-reduction", a->min_reduction_pct, "Acceptance: least held-out RMS reduction [%]")
      ->check(CLI::Range(0.0, 100.0))->capture_default_str();
  cmd->add_flag("--no-plots", a->no_plots, "Skip the matplotlib plots");
  cmd->callback([a] {
    const fs::path in(a->input);
    std::vector<io::NamedPath> outputs;
    for (const char* f : {"gap.json", "model.toml", "series.csv", "report.md"}) outputs.push_back({"--out", fs::path(a->out) / f});
    io::refuse_output_over_input({{"recording", a->input}}, outputs);
    const bool tty = isatty(STDERR_FILENO) != 0;  // progress on a terminal only, quiet in pipes
    gap::keep_freed_memory_for_reuse();
    gap::Options opt;
    opt.folds = a->folds;
    opt.block_s = a->block_s;
    opt.max_steps = a->max_steps;
    opt.min_reduction = a->min_reduction_pct / 100.0;
    if (tty) opt.progress = [](const std::string& m) { std::cerr << "pof gap: " << m << std::endl; };
    io::Recording rec = io::read_recording(a->input);  // CSV or LCM log
    rec.angle_ref_deg = io::reference_angle(rec, nullptr);
    const gap::Result r = gap::analyse(rec, opt);
    gap::write_outputs(r, a->input, a->out);
    if (!a->no_plots) {
      std::string why;
      if (tty) std::cerr << "pof gap: plotting" << std::endl;
      if (!make_plots(a->out, why)) spdlog::warn("plots not written: {}", why);
    }
    std::cout << "baseline gap " << r.baseline_gap_deg << " deg";
    for (const auto& s : r.in_baseline) std::cout << " (in the baseline: " << s.effect << ")";
    for (const auto& s : r.steps) std::cout << " -> " << s.effect << " " << s.gap_deg << " deg";
    std::cout << (r.unexplained ? " (structure remains unexplained)" : "") << "\n";
    // The compensated angle beside the forward gap (docs/gap.md, section 5, "Angle against the forward gap").
    if (r.angle_vs_forward.contains("summary")) std::cout << r.angle_vs_forward["summary"].get<std::string>() << "\n";
    std::cout << "report: " << (fs::path(a->out) / "gap.json").string() << "\n";
  });
}

}  // namespace pof::cli
