// bench_gap: the blind benchmark of `pof gap` (docs/gap.md) and the speed of `pof gap`.
//
//   bench_gap [--blind N] [--seed S] [--out DIR] [--keep] [--no-ceiling] [--dynamic-share P] [--other-family-share Q]
//             [--benchmark_* flags]
//   bench_gap --summarise DIR [DIR ...]
//
// 1. Blind: N recordings from the physics simulator (pof_sim), every 5th with no hidden effect,
//    every 5th+4 with two, the rest with one, effect and magnitude drawn at random per seed; each
//    sensor with its own coefficients, a share P (default 0.5) of them of the dynamic model's kind
//    (tests/generators/src/gap_blind.cpp). Each is written to CSV and analysed from the file alone; then the draw is
//    compared: confusion matrix, effects named correctly, false discoveries on the recordings with
//    nothing hidden, median held-out gap shrink. Summary on stdout, per-trial JSON in DIR.
//    --summarise prints the same summary for the union of earlier runs' DIR/blind.json (the halves
//    of a benchmark run in parallel), from the records alone.
// 2. Speed (Google Benchmark): `pof gap`'s read + analysis of a 40-minute 200 Hz recording of the
//    "realistic" scenario (many effects at once), against the baseline-only analysis
//    (--max-steps 0) of the same file in the same run.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "pof/testing/gap_blind.hpp"
#include "pof/gap/gap.hpp"
#include "pof/gap/io.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/io/csv_writer.hpp"
#include "pof/io/recording_reader.hpp"
#include "pof/sim/effects.hpp"
#include "pof/sim/scenario.hpp"

namespace fs = std::filesystem;

namespace {

fs::path g_dir = fs::temp_directory_path() / "pof_bench_gap";
std::string g_long_csv;
bool g_keep = false;  // --keep: leave the blind CSV files and the 40-min recording in DIR
bool g_ceiling = true;  // --no-ceiling: skip the effect-free draw of each recording (a third of the time)

double median_of(std::vector<double> x) {
  std::sort(x.begin(), x.end());
  return x.empty() ? 0.0 : (x.size() % 2 ? x[x.size() / 2] : 0.5 * (x[x.size() / 2 - 1] + x[x.size() / 2]));
}

// The targets of docs/gap.md, section 6, over a set of trials.
struct Tally {
  std::vector<double> shrink, comp_down, comp_written, comp_nested;  // held-out gap shrink; compensated-angle RMSE reduction
  std::vector<double> comp_steady, transition_share;     // the same outside starts, stops and reversals
  std::vector<double> comp_truth;  // the same against the simulated joint's true angle
  std::vector<double> comp_ceiling;  // the most it can be: the same recording drawn without its effects
  int n = 0, hidden_total = 0, hits = 0, none_trials = 0, none_false = 0, extra = 0;
  int one_trials = 0, one_exact = 0, two_trials = 0, two_both = 0;
  int one_named = 0;  // one hidden effect named (found, or one of a pair said indistinguishable), at most one extra

  void add(const pof::gap::blind::Trial& t, double effect_free_deg) {
    ++n;
    if (t.hidden.empty()) {
      ++none_trials;
      none_false += t.false_finds() > 0 ? 1 : 0;  // a dynamic-kind sensor's own physics named is no discovery
      return;
    }
    if (t.hidden.size() == 1) {
      ++one_trials;
      one_exact += t.correct() ? 1 : 0;
      one_named += t.hits_or_said() == 1 && t.false_finds() <= 1 ? 1 : 0;
    }
    if (t.hidden.size() == 2) { ++two_trials; two_both += t.hits() == 2 ? 1 : 0; }
    hidden_total += static_cast<int>(t.hidden.size());
    hits += t.hits();
    extra += t.false_finds();
    shrink.push_back(t.shrink());
    const auto& c = t.gap["compensated"];
    comp_down.push_back(c.value("reduction_pct", 0.0) / 100.0);  // 0 when the compensator could not run it
    const double before = c.value("rmse_before_deg", 0.0);
    // model.toml holds the baseline when the found model did not beat it: no change then.
    const double written = c.value("model_toml", std::string()) == "found model" ? c.value("rmse_written_deg", before) : before;
    comp_written.push_back(before > 0 ? 1.0 - written / before : 0.0);
    if (c.contains("model_toml_nested")) comp_nested.push_back(c["model_toml_nested"].value("reduction_pct", 0.0) / 100.0);
    comp_truth.push_back(t.truth_before_deg > 0 ? 1.0 - t.truth_after_deg / t.truth_before_deg : 0.0);
    if (before > 0 && std::isfinite(effect_free_deg)) comp_ceiling.push_back(1.0 - effect_free_deg / before);
    if (c.contains("steady")) {
      comp_steady.push_back(c["steady"].value("reduction_pct", 0.0) / 100.0);
      transition_share.push_back(c["steady"].value("transition_share_of_squared_error_before", 0.0));
    }
  }

  void print() const {
    auto pct = [](int a, int b) { return b ? 100.0 * a / b : 0.0; };
    std::printf("recordings: %d (%d with no hidden effect, %d hidden effects in the others)\n", n, none_trials, hidden_total);
    std::printf("effects named correctly: %d / %d = %.1f %%\n", hits, hidden_total, pct(hits, hidden_total));
    std::printf("false discoveries on recordings with no hidden effect: %d / %d = %.1f %%\n", none_false, none_trials,
                pct(none_false, none_trials));
    std::printf("extra (wrong) effects named on recordings with hidden effects: %d\n", extra);
    std::printf("one hidden effect: named with no extra in %d / %d = %.1f %%\n", one_exact, one_trials, pct(one_exact, one_trials));
    std::printf("one hidden effect: named (found, or one of a pair the report says it cannot tell apart), at most one "
                "extra, in %d / %d = %.1f %%\n", one_named, one_trials, pct(one_named, one_trials));
    std::printf("two hidden effects: both named in %d / %d = %.1f %%\n", two_both, two_trials, pct(two_both, two_trials));
    std::vector<double> sorted = shrink;
    std::sort(sorted.begin(), sorted.end());
    std::printf("median held-out gap shrink with an effect hidden: %.1f %% (min %.1f %%, n = %zu)\n", 100 * median_of(shrink),
                sorted.empty() ? 0.0 : 100 * sorted.front(), sorted.size());
    std::printf("median held-out compensated-angle RMSE reduction (pof compensate's angle vs the reference) with an "
                "effect hidden: %.1f %% (n = %zu)\n", 100 * median_of(comp_down), comp_down.size());
    std::printf("the same against the simulated joint's true angle (no reference error at all): %.1f %% (n = %zu)\n",
                100 * median_of(comp_truth), comp_truth.size());
    std::printf("the most it can be (the baseline's angle on the same recording drawn without its hidden effects: "
                "sensor noise, the structure's own error and the reference's noise are left): median %.1f %% (n = %zu)\n",
                100 * median_of(comp_ceiling), comp_ceiling.size());
    std::printf("the same with what model.toml holds (harmful terms left out, chosen on the same blocks: optimistic): "
                "%.1f %%\n", 100 * median_of(comp_written));
    std::printf("the same with what model.toml holds, each block's choice made on the other blocks (nested): "
                "%.1f %% (n = %zu)\n", 100 * median_of(comp_nested), comp_nested.size());
    std::printf("the same outside the 0.5 s after each start, stop and reversal (the step model's own branch errors): "
                "%.1f %% (n = %zu); those 0.5 s hold a median %.0f %% of the baseline's squared error\n",
                100 * median_of(comp_steady), comp_steady.size(), 100 * median_of(transition_share));
  }
};

// A record's number, or `otherwise` where it is absent or null (a NaN is written as null).
double number_or(const nlohmann::json& j, const char* key, double otherwise) {
  return j.contains(key) && j[key].is_number() ? j[key].get<double>() : otherwise;
}

// A trial as far as the summary needs it, from its blind.json record.
pof::gap::blind::Trial trial_of(const nlohmann::json& j) {
  pof::gap::blind::Trial t;
  t.seed = j.at("seed").get<std::uint64_t>();
  if (j.contains("hidden"))
    for (const auto& h : j["hidden"]) t.hidden.push_back({h.at("effect").get<std::string>(), h.value("truth", nlohmann::json())});
  t.found = j.at("found").get<std::vector<std::string>>();
  if (j.contains("covered")) t.covered = j["covered"].get<std::vector<std::string>>();
  if (j.contains("said")) t.said = j["said"].get<std::vector<std::string>>();
  t.baseline_gap_deg = number_or(j, "baseline_gap_deg", 0.0);
  t.final_gap_deg = number_or(j, "final_gap_deg", 0.0);
  t.analysis_s = number_or(j, "analysis_s", 0.0);
  t.truth_before_deg = number_or(j.at("compensated_vs_truth"), "rmse_before_deg", 0.0);
  t.truth_after_deg = number_or(j.at("compensated_vs_truth"), "rmse_after_deg", 0.0);
  t.gap["compensated"] = j.at("compensated");
  return t;
}

// The summary of a set of blind.json records: confusion matrix, then the targets over all
// recordings and per sensor kind.
void summarise(const nlohmann::json& records) {
  std::map<std::string, std::map<std::string, int>> confusion;  // hidden -> named -> count
  Tally all_trials;
  std::map<std::string, Tally> by_sensor;       // "paper" / "dynamic" sensor
  std::map<std::string, Tally> by_family;       // the sensor's hysteresis family: paper steps, bouc_wen, maxwell_slip
  std::map<std::string, std::array<int, 3>> by_effect;  // hidden effect -> times hidden, found, found or said
  std::map<std::string, int> baseline_choice;   // "<sensor> sensor -> <baseline> baseline"
  double worst_time = 0;
  for (const auto& j : records) {
    const pof::gap::blind::Trial t = trial_of(j);
    const std::string sensor = j.at("sensor").get<std::string>();
    const nlohmann::json choice = j.value("baseline_choice", nlohmann::json());
    const std::string chosen = choice.is_object() ? choice.value("chosen", "?") : "?";
    const double effect_free_deg = number_or(j, "compensated_effect_free_rmse_deg", std::nan(""));
    worst_time = std::max(worst_time, t.analysis_s);
    all_trials.add(t, t.hidden.empty() ? std::nan("") : effect_free_deg);
    by_sensor[sensor].add(t, t.hidden.empty() ? std::nan("") : effect_free_deg);
    const std::string family = j.contains("dynamic_sensor") ? j["dynamic_sensor"]["memory"].value("family", "?") : "paper steps";
    by_family[family].add(t, t.hidden.empty() ? std::nan("") : effect_free_deg);
    for (const auto& h : t.hidden) {
      const bool found = std::count(t.found.begin(), t.found.end(), h.effect) > 0;
      auto& e = by_effect[h.effect];
      e[0]++;
      e[1] += found ? 1 : 0;
      e[2] += found || std::count(t.said.begin(), t.said.end(), h.effect) > 0 ? 1 : 0;
    }
    baseline_choice[sensor + " sensor -> " + chosen + " baseline"]++;
    // A dynamic-kind sensor's own physics named (Trial::covered) is neither a hit nor a wrong name.
    auto own = [&](const std::string& f) { return std::find(t.covered.begin(), t.covered.end(), f) != t.covered.end(); };
    if (t.hidden.empty()) {
      std::string first = "none";
      for (const auto& f : t.found)
        if (!own(f)) { first = f; break; }
      confusion["none"][first]++;
    } else {
      for (const auto& h : t.hidden) {
        const bool hit = std::count(t.found.begin(), t.found.end(), h.effect) > 0;
        std::string col = "none";
        if (hit) col = h.effect;
        else
          for (const auto& f : t.found)
            if (!own(f) && std::none_of(t.hidden.begin(), t.hidden.end(), [&](const auto& x) { return x.effect == f; })) { col = f; break; }
        confusion[h.effect][col]++;
      }
    }
  }
  // Markdown, ready for BENCHMARKS.md.
  std::vector<std::string> cols{"none"};
  for (auto id : pof::core::kEffectIds) cols.emplace_back(id);
  auto abbrev = [](const std::string& s) {
    static const std::map<std::string, std::string> a{{"none", "none"}, {"static_nonlinearity", "stat"}, {"drift", "drift"},
        {"creep", "creep"}, {"rate_dependent_hysteresis", "rdh"}, {"acceleration_dependence", "acc"}, {"time_delay", "delay"},
        {"backlash", "backl"}, {"source_power_coupling", "power"}, {"periodic_interference", "period"},
        {"memory_hysteresis", "mem"}, {"viscoelastic_relaxation", "visco"}};
    return a.at(s);
  };
  std::cout << "\nConfusion matrix (rows: hidden effect, one row entry per hidden effect; columns: the effect named "
               "for it: itself if found, else the first wrongly named one, else none)\n\n| hidden \\ named |";
  for (const auto& c : cols) std::cout << ' ' << abbrev(c) << " |";
  std::cout << "\n|---|";
  for (std::size_t i = 0; i < cols.size(); ++i) std::cout << "---|";
  std::cout << '\n';
  for (const auto& r : cols) {
    if (!confusion.count(r)) continue;
    std::cout << "| " << r << " |";
    for (const auto& c : cols) {
      const int v = confusion[r].count(c) ? confusion[r][c] : 0;
      std::cout << ' ' << (v ? std::to_string(v) : std::string(".")) << " |";
    }
    std::cout << '\n';
  }
  std::printf("\nAll recordings\n");
  all_trials.print();
  for (const auto& [sensor, tally] : by_sensor) {
    std::printf("\nSensors of the %s kind\n", sensor.c_str());
    tally.print();
  }
  for (const auto& [family, tally] : by_family) {
    std::printf("\nSensors whose hysteresis is %s\n", family.c_str());
    tally.print();
  }
  std::printf("\nBy hidden effect (found: a step or in the baseline; or said: one of a pair the report says it cannot "
              "tell apart)\n\n| effect | hidden | found | found or said | %% |\n|---|---|---|---|---|\n");
  for (const auto& [effect, c] : by_effect)
    std::printf("| %s | %d | %d | %d | %.0f |\n", effect.c_str(), c[0], c[1], c[2], c[0] ? 100.0 * c[2] / c[0] : 0.0);
  std::printf("\nbaseline taken:");
  for (const auto& [k, v] : baseline_choice) std::printf(" %s %d;", k.c_str(), v);
  std::printf("\nslowest analysis: %.2f s\n\n", worst_time);
  std::fflush(stdout);
}

void run_blind(int n, std::uint64_t seed0, double dynamic_share, double other_family_share) {
  using pof::gap::blind::Trial;
  nlohmann::json all = nlohmann::json::array();
  std::cerr << "blind benchmark: " << n << " recordings\n";
  for (int i = 0; i < n; ++i) {
    // The number of hidden effects follows the seed: seed % 5 == 1 none, == 0 two, else one.
    const std::uint64_t seed = seed0 + static_cast<std::uint64_t>(i);
    const int count = seed % 5 == 1 ? 0 : (seed % 5 == 0 ? 2 : 1);
    const Trial t = pof::gap::blind::run_trial(seed, count, false, g_dir, {}, 0.3, dynamic_share, other_family_share);
    if (!g_keep) fs::remove(t.csv);
    const std::string sensor = t.dynamic.is_null() ? "paper" : "dynamic";
    const std::string chosen = t.gap["baseline"].contains("choice") ? t.gap["baseline"]["choice"].value("chosen", "?") : "?";
    std::string hid, fnd;
    for (const auto& h : t.hidden) hid += (hid.empty() ? "" : "+") + h.effect;
    for (const auto& f : t.found) fnd += (fnd.empty() ? "" : "+") + f;
    std::fprintf(stderr, "  seed %3llu %-7s sensor, %-7s baseline, hidden %-45s found %-45s gap %.3f -> %.3f deg (%.1f s)\n",
                 static_cast<unsigned long long>(seed), sensor.c_str(), chosen.c_str(), hid.empty() ? "none" : hid.c_str(),
                 fnd.empty() ? "none" : fnd.c_str(), t.baseline_gap_deg, t.final_gap_deg, t.analysis_s);
    // The ceiling of its compensated reduction: the same sensor drawn without the hidden effects.
    const double effect_free_deg = t.hidden.empty() || !g_ceiling ? std::nan("")
                                                    : pof::gap::blind::effect_free_rmse(seed, false, g_dir, 0.3, dynamic_share,
                                                                                        other_family_share);
    nlohmann::json j{{"seed", seed}, {"sensor", sensor}, {"found", t.found}, {"baseline_gap_deg", t.baseline_gap_deg},
                     {"said", t.said}, {"final_gap_deg", t.final_gap_deg}, {"analysis_s", t.analysis_s},
                     {"compensated", t.gap["compensated"]}, {"baseline", t.gap["baseline"]["refit_rms_mv"]},
                     {"compensated_vs_truth", {{"rmse_before_deg", t.truth_before_deg}, {"rmse_after_deg", t.truth_after_deg}}},
                     {"compensated_effect_free_rmse_deg", effect_free_deg},
                     {"baseline_choice", t.gap["baseline"].value("choice", nlohmann::json())}};
    if (t.gap["baseline"].contains("dynamic")) {
      j["baseline_dynamic"] = t.gap["baseline"]["dynamic"];
      j["baseline_dynamic"].erase("model");
    }
    if (!t.dynamic.is_null()) {
      j["dynamic_sensor"] = t.dynamic;
      j["covered"] = t.covered;
    }
    for (const auto& h : t.hidden) j["hidden"].push_back({{"effect", h.effect}, {"truth", h.truth}});
    j["in_baseline"] = t.gap["in_baseline"];
    j["steps"] = t.gap["steps"];
    all.push_back(j);
    // After every recording, so a run stopped by a time limit leaves the records it has.
    pof::io::write_file_atomic(g_dir / "blind.json", all.dump(1) + "\n");
  }
  summarise(all);
}

void make_long_recording() {
  pof::sim::Scenario s = pof::sim::builtin_scenario("realistic");
  s.loop = true;
  s.duration_s = 2400;  // 40 min at the scenario's 200 Hz
  g_long_csv = (g_dir / "realistic_40min.csv").string();
  pof::io::write_csv(g_long_csv, pof::gap::blind::simulate(s, 1));
}

// Process CPU time (all threads), next to Google Benchmark's wall-clock time: the machine this runs
// on is shared, and the CPU seconds say what the analysis itself costs.
double cpu_seconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

void BM_Gap40minBaselineOnly(benchmark::State& st) {
  pof::gap::Options opt;
  opt.max_steps = 0;
  const double c0 = cpu_seconds();
  for (auto _ : st) benchmark::DoNotOptimize(pof::gap::analyse(pof::io::read_csv(g_long_csv), opt));
  st.counters["cpu_s_per_run"] = (cpu_seconds() - c0) / static_cast<double>(st.iterations());
}
void BM_Gap40minFull(benchmark::State& st) {
  pof::gap::Options opt;
  std::size_t steps = 0;
  const double c0 = cpu_seconds();
  for (auto _ : st) steps = pof::gap::analyse(pof::io::read_csv(g_long_csv), opt).steps.size();
  st.counters["cpu_s_per_run"] = (cpu_seconds() - c0) / static_cast<double>(st.iterations());
  st.counters["steps"] = static_cast<double>(steps);
}
BENCHMARK(BM_Gap40minBaselineOnly)->Unit(benchmark::kSecond)->Iterations(2)->UseRealTime();
BENCHMARK(BM_Gap40minFull)->Unit(benchmark::kSecond)->Iterations(2)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  int n = 50;
  std::uint64_t seed = 1;
  double dynamic_share = 0.5, other_family_share = 0.0;
  std::vector<char*> rest{argv[0]};
  std::vector<fs::path> summarise_dirs;
  bool summarise_only = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--summarise") {
      summarise_only = true;
      while (i + 1 < argc && std::string(argv[i + 1]).rfind("--", 0) != 0) summarise_dirs.emplace_back(argv[++i]);
    } else if (a == "--blind" && i + 1 < argc) n = std::atoi(argv[++i]);
    else if (a == "--seed" && i + 1 < argc) seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--out" && i + 1 < argc) g_dir = argv[++i];
    else if (a == "--keep") g_keep = true;
    else if (a == "--no-ceiling") g_ceiling = false;
    else if (a == "--dynamic-share" && i + 1 < argc) dynamic_share = std::atof(argv[++i]);
    else if (a == "--other-family-share" && i + 1 < argc) other_family_share = std::atof(argv[++i]);
    else if (a == "--help" || a == "-h") {
      std::cout << "usage: bench_gap [--blind N] [--seed S] [--out DIR] [--keep] [--dynamic-share P] [--other-family-share Q]"
                   " [benchmark flags]\n"
                   "       bench_gap --summarise DIR [DIR ...]\n"
                   "  --blind N          blind recordings to draw and analyse (default 50; 0: the timing benchmarks only)\n"
                   "  --seed S           the first recording's seed (default 1; recording i has seed S + i)\n"
                   "  --out DIR          where blind.json, the CSVs and the 40-min recording go\n"
                   "  --keep             keep each blind recording's CSV and the 40-min recording\n"
                   "  --no-ceiling       skip each recording's effect-free draw (the compensated reduction's ceiling)\n"
                   "  --dynamic-share P  share of sensors of the dynamic model's kind (default 0.5)\n"
                   "  --other-family-share Q  share of those whose memory is a Preisach density and relaxation a power\n"
                   "                     law, families the dynamic model does not contain (default 0)\n"
                   "  --summarise DIR... the summary of earlier runs' DIR/blind.json together (halves run in parallel)\n"
                   "  --benchmark_filter=NONE skips the timing benchmarks; the benchmark library's flags follow:\n\n";
      rest.push_back(argv[i]);
      n = 0;
    } else rest.push_back(argv[i]);
  }
  if (summarise_only) {
    if (summarise_dirs.empty()) {
      std::cerr << "bench_gap: --summarise needs at least one DIR holding a blind.json\n";
      return 2;
    }
    nlohmann::json all = nlohmann::json::array();
    for (const fs::path& d : summarise_dirs) {
      const fs::path f = d / "blind.json";
      std::ifstream in(f);
      if (!in) {
        std::cerr << "bench_gap: " << f.string() << ": cannot open (a DIR of an earlier --blind run was expected)\n";
        return 66;
      }
      const nlohmann::json part = nlohmann::json::parse(in, nullptr, false);
      if (!part.is_array()) {
        std::cerr << "bench_gap: " << f.string() << ": not a JSON array of blind trials\n";
        return 65;
      }
      try {
        for (const auto& j : part) (void)trial_of(j);  // every record readable before anything is printed
      } catch (const nlohmann::json::exception& e) {
        std::cerr << "bench_gap: " << f.string() << ": a trial record lacks what the summary needs: " << e.what() << "\n";
        return 65;
      }
      all.insert(all.end(), part.begin(), part.end());
    }
    std::cerr << "blind benchmark summary: " << all.size() << " recordings from " << summarise_dirs.size() << " run(s)\n";
    summarise(all);
    return 0;
  }
  pof::gap::keep_freed_memory_for_reuse();  // as `pof gap` does
  fs::create_directories(g_dir);
  if (n > 0) run_blind(n, seed, dynamic_share, other_family_share);
  int rc = static_cast<int>(rest.size());
  benchmark::Initialize(&rc, rest.data());
  make_long_recording();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (!g_keep) fs::remove(g_long_csv);
  return 0;
}
