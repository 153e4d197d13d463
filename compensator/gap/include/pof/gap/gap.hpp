#pragma once
// `pof gap`: where do the baseline (the paper's model structure, eqs. 11/12 inverted, f5 in
// holds, or the dynamic model, whichever explains the recording better, with its coefficients
// fitted to the recording) and a recording disagree, which physical
// effect is missing, and how much of the gap does adding it close. See docs/gap.md for the method and the acceptance rule.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "pof/core/dynamic_model.hpp"
#include "pof/core/model.hpp"
#include "pof/io/recording.hpp"

namespace pof::gap {

struct Result;

struct Options {
  int folds = 5;                 // time-blocked folds (boundaries moved into holds: whole cycles)
  double block_s = 25;           // each fold's blocks about this long, dealt out in turn (0: one block per fold)
  double min_reduction = 0.05;   // accept only if held-out RMS drops by >= 5 % ...
  double min_delta_bic = 10.0;   // ... AND held-out BIC (effective n) improves by > 10
  int max_steps = 4;
  int threads = 2;               // candidates are evaluated in parallel
  /// Called with one-line progress messages (the CLI prints them only on a terminal).
  std::function<void(const std::string&)> progress;
  /// Called with the report as it stands after each stage (the baseline, each accepted step of
  /// each search, the searches' end), so a run stopped later leaves a report whole up to there
  /// (docs/gap.md, section 5, "Written as it goes"). Not called for the finished result, which
  /// analyse() returns.
  std::function<void(const Result&)> checkpoint;
};

struct Step {
  std::string effect;
  double gap_deg = 0;            // held-out RMS residual [deg] after adding this effect
  std::string where;             // where the effect's contribution is concentrated, in words
  nlohmann::json parameters;     // physical parameters (+ "<name>_se" jackknife standard errors)
  nlohmann::json evidence;       // scores of every candidate, phase RMS before/after, ...
};

/// Time series for plots (one row per kept scan).
struct Series {
  std::vector<double> t, angle, w, v, model_baseline, model_final, resid_baseline_deg, resid_final_deg;
  std::vector<double> angle_comp_before, angle_comp_after;  // the compensator's angle, baseline / found model
};

struct Result {
  /// The stage this result is whole up to: "complete", or what a checkpoint had reached.
  std::string stage = "complete";
  [[nodiscard]] bool complete() const { return stage == "complete"; }
  double baseline_gap_deg = 0;
  /// Effects of the catalogue the chosen baseline structure carries itself, found by its own
  /// cross-validation rather than by the search (docs/gap.md, section 1, "What the baseline
  /// names"): the dynamic model's bend lag is a `time_delay`. gap_deg is the baseline's held-out gap.
  std::vector<Step> in_baseline;
  std::vector<Step> steps;
  double final_gap_deg = 0;
  bool unexplained = false;
  /// Explanations this recording cannot tell apart, each with what would (docs/gap.md, section 4,
  /// "Said, not hidden"): candidates that explain the same residual alike, the share of a loop
  /// between a dead band in the reference and a play in the fibre, a delay and a bend lag.
  nlohmann::json indistinguishable = nlohmann::json::array();
  nlohmann::json baseline;       // fitted baseline (c9, c10), localisation of the baseline residual
  nlohmann::json whiteness;      // final residual: ACF, Ljung-Box, noise floor
  nlohmann::json model;          // improved model: coefficients + accepted terms (for model.toml)
  nlohmann::json recording;      // n, rate, duration, reference level
  nlohmann::json compensated;    // the compensator's angle vs the reference on held-out blocks, before/after
  nlohmann::json angle_vs_forward;  // that angle beside the forward gap, and where they differ (pof/gap/angle_gap.hpp)
  std::optional<core::DynamicModel> dynamic_model;  // model.toml's active model when the dynamic baseline was taken
  Series series;

  [[nodiscard]] nlohmann::json to_json() const;
};

/// Runs the whole workflow on one recording. Throws pof::DataError when the recording cannot be
/// analysed (too short, no movement, no holds, non-constant rate), naming the source.
Result analyse(const io::Recording& rec, const Options& opt = {});

/// For a process that runs analyse() as a batch job (`pof gap`, bench_gap), called before any
/// thread starts: freed memory stays in the process's one heap for the next allocation. The search
/// builds and frees a design of ~50-100 MB for every value of a kinematic candidate's grid (a few
/// hundred per step on 40 min); glibc serves each from fresh mmap pages the kernel zeroes on first
/// touch, a quarter of the run's time (compensator/gap/src/batch_memory.cpp has the figures). Not for a daemon.
void keep_freed_memory_for_reuse();

}  // namespace pof::gap
