// `pof gap <recording> --out DIR`: where the baseline model and the recording disagree,
// which physical effect is missing, and how much adding it closes the gap. Method: docs/gap.md.
// Built into its own program, pof-gap, which `pof gap` runs (helper.cpp says why).
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <thread>
#include <utility>
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

// The report written as the analysis goes (docs/gap.md, section 5, "Written as it goes"). Each
// stage is written into a staging folder inside DIR and plotted there while the analysis goes on,
// then moved into DIR, plots first and gap.json last, so that DIR holds a report whole up to the
// last stage moved: a run stopped by a time limit leaves that one, plots included. Plotting
// failures are reported, not fatal; the numbers are moved all the same.
class StagedReport {
 public:
  StagedReport(fs::path dir, std::string source, bool plots, bool tty)
      : dir_(std::move(dir)), staging_(dir_ / ".pof-gap-stage"), source_(std::move(source)), plots_(plots), tty_(tty) {}
  StagedReport(const StagedReport&) = delete;
  StagedReport& operator=(const StagedReport&) = delete;
  ~StagedReport() {
    if (job_.joinable()) job_.join();
  }

  // A checkpoint: written now, plotted and moved into DIR in the background.
  void stage(const gap::Result& r) {
    write(r);
    job_ = std::thread([this] { plot_and_publish(); });
  }

  // The finished analysis: written, plotted and moved before returning.
  void finish(const gap::Result& r) {
    write(r);
    if (plots_ && tty_) std::cerr << "pof gap: plotting" << std::endl;
    plot_and_publish();
    std::error_code ec;
    fs::remove_all(staging_, ec);
  }

 private:
  // The files of a report in the order they are moved: plots, then the numbers, gap.json last.
  static constexpr const char* kPlots[] = {"residual_time.png", "residual_angle.png", "residual_velocity.png",
                                           "loops.png",         "gap_steps.png",      "compensated.png"};
  static constexpr const char* kNumbers[] = {"series.csv", "report.md", "model.toml", "gap.json"};

  void write(const gap::Result& r) {
    if (job_.joinable()) job_.join();  // the previous stage is in DIR before this one is staged
    std::error_code ec;
    fs::remove_all(staging_, ec);
    gap::write_outputs(r, source_, staging_);
  }

  void plot_and_publish() {
    if (plots_) {
      try {
        run_plot_script("gap_report.py", {staging_.string()});
      } catch (const pof::IoError& e) {
        spdlog::warn("plots not written: {}", e.what());
      }
    }
    // A file this stage has replaces DIR's; one it lacks (model.toml before the last stage, the
    // plots of a failed plotting, compensated.png before the compensator ran) is removed after
    // gap.json is in, so no earlier stage's or run's file stands beside it. Without plots
    // (--no-plots) the PNGs in DIR are left as they are.
    std::vector<fs::path> absent;
    auto move = [&](const char* f) {
      std::error_code ec;
      if (fs::exists(staging_ / f, ec)) {
        fs::rename(staging_ / f, dir_ / f, ec);
        if (ec) spdlog::warn("{}: not written: {}", (dir_ / f).string(), ec.message());
      } else {
        absent.push_back(dir_ / f);
      }
    };
    if (plots_)
      for (const char* f : kPlots) move(f);
    for (const char* f : kNumbers) move(f);
    for (const fs::path& p : absent) {
      std::error_code ec;
      fs::remove(p, ec);
    }
  }

  fs::path dir_, staging_;
  std::string source_;
  bool plots_, tty_;
  std::thread job_;
};

}  // namespace

void setup_gap(CLI::App& app) {
  app.description(kGapSummary);
  struct Args {
    std::string input, out;
    int folds = 5, max_steps = 4;
    double min_reduction_pct = 5, block_s = gap::Options{}.block_s;
    bool no_plots = false;
  };
  auto a = std::make_shared<Args>();
  app.add_option("recording", a->input, "Recording: CSV t_s,sensor_v,reference_v,angle_ref_deg, or an LCM log of POF_RAW blocks")->required();
  app.add_option("--out,-o", a->out, "Output directory (gap.json, model.toml, report.md, PNG plots)")->required();
  app.add_option("--folds", a->folds, "Time-blocked cross-validation folds")->check(CLI::Range(2, 20))->capture_default_str();
  app.add_option("--block-seconds", a->block_s,
                 "Length of the folds' time blocks, dealt to the folds in turn [s]; 0: one contiguous block per fold")
      ->check(CLI::Range(0.0, 3600.0))->capture_default_str();
  app.add_option("--max-steps", a->max_steps, "Most effects to add")->check(CLI::Range(0, 9))->capture_default_str();
  app.add_option("--min-reduction", a->min_reduction_pct, "Acceptance: least held-out RMS reduction [%]")
      ->check(CLI::Range(0.0, 100.0))->capture_default_str();
  app.add_flag("--no-plots", a->no_plots, "Skip the matplotlib plots");
  app.callback([a] {
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
    StagedReport report(a->out, a->input, !a->no_plots, tty);
    opt.checkpoint = [&report](const gap::Result& partial) { report.stage(partial); };
    const gap::Result r = gap::analyse(rec, opt);
    report.finish(r);
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
