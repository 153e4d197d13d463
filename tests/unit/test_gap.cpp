// `pof gap` candidates on fixed seeds : each candidate on a fixed seed.
// Each test hides one effect in a short synthetic calibration session (pof::gap::synthesise) and
// checks that the first accepted step names it, recovers its physical parameter, and at least
// halves the held-out gap (or ends near the noise floor); a recording with no hidden effect must
// give no step.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>
#include <vector>
#include <set>
#include <string>

#include "pof/gap/gap.hpp"
#include "pof/gap/io.hpp"
#include "pof/io/calibration_file.hpp"
#include "pof/gap/signals.hpp"
#include "pof/testing/gap_synth.hpp"
#include "pof/base/errors.hpp"
#include "pof/core/dynamic_model.hpp"
#include "pof/core/model.hpp"
#include "temp_dir.hpp"

namespace {

pof::gap::Result run(const std::string& effect, double magnitude, std::uint64_t seed = 7) {
  pof::gap::SynthConfig cfg;
  cfg.short_protocol = true;
  cfg.extra_seconds = 60;       // gait-like movement: accelerations for acceleration_dependence
  cfg.reference_wander = 0.02;  // light source wanders (cancelled unless coupled)
  if (!effect.empty()) cfg.effects[effect] = magnitude;
  return pof::gap::analyse(pof::gap::synthesise(cfg, seed));
}

double param(const pof::gap::Result& r, const char* name) { return r.steps.at(0).parameters.at(name).get<double>(); }

void expect_named(const pof::gap::Result& r, const std::string& effect) {
  ASSERT_FALSE(r.steps.empty()) << "nothing found; baseline gap " << r.baseline_gap_deg;
  EXPECT_EQ(r.steps[0].effect, effect) << r.to_json().dump(1).substr(0, 2000);
  // The gap at least halves, or ends within 1.5x the scan-to-scan noise floor: the baseline
  // structure, refitted to the recording, may already take part of an effect (a delay looks partly
  // like hysteresis), leaving less to shrink.
  const double floor = r.whiteness.at("noise_floor_deg").get<double>();
  EXPECT_LE(r.steps[0].gap_deg, std::max(0.5 * r.baseline_gap_deg, 1.5 * floor)) << "noise floor " << floor;
  EXPECT_FALSE(r.steps[0].where.empty());
}

}  // namespace

TEST(GapCandidates, NoHiddenEffectGivesNoStep) {
  const auto r = run("", 0);
  EXPECT_TRUE(r.steps.empty()) << r.steps.front().effect;
  EXPECT_NEAR(r.final_gap_deg, r.baseline_gap_deg, 1e-12);
  EXPECT_LT(r.baseline_gap_deg, 0.2);  // ~ sensor noise 2 mV * 45.7 deg/V
}
TEST(GapCandidates, OwnCoefficientsAreNoEffect) {
  // A sensor of the paper's structure with coefficients of its own (each of c1, c2, c3-c6, c9, c10
  // 15-30 % off table 2): the baseline is fitted to the recording, so nothing is missing.
  pof::gap::SynthConfig cfg;
  cfg.short_protocol = true;
  cfg.extra_seconds = 60;
  cfg.reference_wander = 0.02;
  auto& m = cfg.model;
  m.c1 *= 1.3;
  m.c2 *= 0.75;
  m.c9 *= 1.2;
  m.c10 *= 0.85;
  m.flexion.c3 *= 1.25;
  m.flexion.c5 *= 0.8;
  m.extension.c4 *= 1.15;
  m.extension.c6 *= 0.8;
  m.extension.c7 = 1.0098 / m.extension.c4;  // the chain stays near identity at zero hysteresis
  m.extension.c8 = 1.0334 * m.extension.c7 * m.extension.c6;
  const auto r = pof::gap::analyse(pof::gap::synthesise(cfg, 7));
  EXPECT_TRUE(r.steps.empty()) << r.steps.front().effect << " " << r.steps.front().parameters.dump();
  EXPECT_LT(r.baseline_gap_deg, 0.2);  // ~ sensor noise 2 mV * ~55 deg/V
}
TEST(GapCandidates, StaticNonlinearity) {
  const auto r = run("static_nonlinearity", 1.5);
  expect_named(r, "static_nonlinearity");
  EXPECT_GT(param(r, "quadratic_deg"), 0.5);
}
TEST(GapCandidates, Drift) {
  const auto r = run("drift", 1.0);
  expect_named(r, "drift");
  const double total = param(r, "drift_deg_per_min") * r.recording["duration_s"].get<double>() / 60.0;
  EXPECT_NEAR(total, 1.0, 0.15);
  // The drift is refused online, so nothing found is applied: the compensated angle is the
  // baseline's, fitted without a drift column. Fitted beside one and applied without it, the
  // structure lost the share of the trend its offset had taken (blind recordings: 17-34 % worse).
  const auto& c = r.compensated;
  EXPECT_EQ(c.at("not_applied"), nlohmann::json::array({"drift"}));
  EXPECT_EQ(c.at("model_toml").get<std::string>(), "baseline (the compensator can apply none of the effects found)");
  EXPECT_LT(c.at("rmse_after_deg").get<double>(), 1.02 * c.at("rmse_before_deg").get<double>()) << c.dump(1).substr(0, 1500);
}
// A drift is found but has no online form (a trend over this recording): the model.toml `pof gap`
// writes must still load in the compensator, so the drift is named in the report and left out of
// the file, beside the interference that is written. On this seed the file held both, and
// pof compensate refused it ("[gap] term 2 'drift': a trend over the calibration recording cannot
// be applied online").
TEST(GapCandidates, ADriftFoundIsNotWrittenAndTheModelLoads) {
  pof::gap::SynthConfig cfg;
  cfg.short_protocol = true;
  cfg.extra_seconds = 60;
  cfg.reference_wander = 0.02;
  cfg.effects = {{"drift", 1.0}, {"periodic_interference", 0.008}};
  const auto r = pof::gap::analyse(pof::gap::synthesise(cfg, 7));
  std::set<std::string> found;
  for (const auto& st : r.steps) found.insert(st.effect);
  ASSERT_TRUE(found.count("drift") && found.count("periodic_interference")) << r.to_json().at("steps").dump().substr(0, 800);
  EXPECT_EQ(r.compensated.at("not_applied"), nlohmann::json::array({"drift"}));
  ASSERT_EQ(r.compensated.at("model_toml").get<std::string>(), "found model") << "the test needs a seed whose model is written";
  std::set<std::string> written;
  for (const auto& t : r.model.at("terms")) written.insert(t.at("effect").get<std::string>());
  EXPECT_EQ(written, std::set<std::string>{"periodic_interference"});
  const pof::test::TempDir dir("pof-gap-drift");
  pof::gap::write_outputs(r, "synthetic", dir.path());
  EXPECT_NO_THROW(pof::io::load_calibration(dir.path("model.toml"), "", 200.0));
}
TEST(GapCandidates, Creep) {
  const auto r = run("creep", 0.08);
  expect_named(r, "creep");
  EXPECT_NEAR(param(r, "tau_s"), 4.0, 1.5);
}
// Written as it goes (docs/gap.md, section 5): the checkpoints are the report so far, each whole
// (baseline, residual, where it lies, the plotted series) and said to be a stage, never a model;
// the paper structure's search passes through every prefix of its steps.
TEST(GapReport, CheckpointsAreTheReportSoFar) {
  pof::gap::SynthConfig cfg;
  cfg.short_protocol = true;
  cfg.extra_seconds = 60;
  cfg.reference_wander = 0.02;
  cfg.effects = {{"creep", 0.08}, {"periodic_interference", 0.008}};
  std::vector<pof::gap::Result> stages;
  pof::gap::Options opt;
  opt.checkpoint = [&stages](const pof::gap::Result& r) { stages.push_back(r); };
  const auto r = pof::gap::analyse(pof::gap::synthesise(cfg, 23), opt);
  ASSERT_TRUE(r.complete());
  EXPECT_FALSE(r.to_json().contains("stage"));
  ASSERT_GE(stages.size(), 3U) << "the baseline, at least one step, the searches' end";
  const auto& choice = r.baseline.at("choice");
  EXPECT_TRUE(stages.front().steps.empty());
  EXPECT_DOUBLE_EQ(stages.front().baseline_gap_deg, choice.at("paper").at("heldout_gap_deg").get<double>());
  std::size_t paper_steps = 0;
  for (const auto& st : stages) {
    EXPECT_FALSE(st.complete());
    EXPECT_EQ(st.to_json().at("stage").get<std::string>(), st.stage);
    EXPECT_TRUE(st.whiteness.contains("final_where")) << st.stage;
    ASSERT_FALSE(st.series.t.empty()) << st.stage;
    EXPECT_TRUE(std::isnan(st.series.angle_comp_after.front())) << "no compensated angle before the compensator ran";
    EXPECT_TRUE(st.model.is_null()) << st.stage;
    if (st.stage.rfind("searching from the paper structure", 0) == 0) {
      EXPECT_EQ(st.steps.size(), ++paper_steps) << st.stage;
    }
  }
  EXPECT_EQ(paper_steps, choice.at("paper").at("steps").get<std::size_t>());
  const auto& last = stages.back();  // the searches done: the kept search's steps, as the result has them
  ASSERT_EQ(last.steps.size(), r.steps.size());
  for (std::size_t i = 0; i < r.steps.size(); ++i) EXPECT_EQ(last.steps[i].effect, r.steps[i].effect);
  EXPECT_DOUBLE_EQ(last.final_gap_deg, r.final_gap_deg);
  const pof::test::TempDir dir("pof-gap-stage");
  pof::gap::write_outputs(stages.front(), "synthetic", dir.path());
  EXPECT_FALSE(std::filesystem::exists(dir.path("model.toml")));
  EXPECT_TRUE(std::filesystem::exists(dir.path("gap.json")));
}
TEST(GapCandidates, RateDependentHysteresis) {
  const auto r = run("rate_dependent_hysteresis", 0.02);
  expect_named(r, "rate_dependent_hysteresis");
  EXPECT_NEAR(param(r, "amplitude_mv"), 20.0, 4.0);
  EXPECT_NEAR(param(r, "velocity_scale_rad_s"), 0.1, 0.05);
}
TEST(GapCandidates, AccelerationDependence) {
  const auto r = run("acceleration_dependence", 0.6);
  expect_named(r, "acceleration_dependence");
  EXPECT_NEAR(param(r, "gain_deg_per_rad_s2"), 0.6, 0.25);
}
TEST(GapCandidates, TimeDelay) {
  const auto r = run("time_delay", 0.030);
  expect_named(r, "time_delay");
  EXPECT_NEAR(param(r, "delay_ms"), 30.0, 3.0);
}
TEST(GapCandidates, Backlash) {
  const auto r = run("backlash", 1.5);
  expect_named(r, "backlash");
  EXPECT_NEAR(param(r, "width_deg"), 1.5, 0.6);
}
TEST(GapCandidates, SourcePowerCoupling) {
  const auto r = run("source_power_coupling", 0.25);
  expect_named(r, "source_power_coupling");
  EXPECT_NEAR(param(r, "gamma"), 0.25, 0.03);
}
TEST(GapCandidates, PeriodicInterference) {
  const auto r = run("periodic_interference", 0.008);
  expect_named(r, "periodic_interference");
  EXPECT_NEAR(param(r, "frequency_hz"), 50.0, 0.01);
  EXPECT_NEAR(param(r, "amplitude_mv"), 8.0, 1.0);
}
TEST(GapCandidates, MemoryHysteresis) {
  const auto r = run("memory_hysteresis", 0.02);
  expect_named(r, "memory_hysteresis");
  // The hysteron's 0.02 V half-height is 0.91 deg at the paper's 45.7 deg/V.
  EXPECT_NEAR(std::abs(param(r, "half_height_deg")), 0.91, 0.3);
  // What model.toml holds runs every loop the same way round: operator weights of one sign.
  int written = 0;
  for (const auto& t : r.model.at("terms")) {
    if (t.at("effect") != "memory_hysteresis") continue;
    ++written;
    bool positive = false, negative = false;
    for (const auto& c : t.at("coefficients_v")) {
      positive = positive || c.get<double>() > 0;
      negative = negative || c.get<double>() < 0;
    }
    EXPECT_FALSE(positive && negative) << t.dump();
  }
  EXPECT_EQ(written, 1) << r.model.dump(1);
}
TEST(GapCandidates, ViscoelasticRelaxation) {
  const auto r = run("viscoelastic_relaxation", 0.08);
  expect_named(r, "viscoelastic_relaxation");
  EXPECT_NEAR(param(r, "total_gain"), 0.08, 0.03);
  // The generator's time constants are 1.5 s and 40 s; the short session's 10 s holds see the slow
  // one only in part.
  EXPECT_NEAR(param(r, "tau_fast_s"), 1.5, 1.0);
  EXPECT_GT(param(r, "tau_slow_s"), 10.0);
}
TEST(GapCandidates, TwoEffectsAreBothFound) {
  pof::gap::SynthConfig cfg;
  cfg.short_protocol = true;
  cfg.extra_seconds = 60;
  cfg.effects = {{"creep", 0.06}, {"time_delay", 0.03}};
  const auto r = pof::gap::analyse(pof::gap::synthesise(cfg, 11));
  ASSERT_GE(r.steps.size(), 2u);
  std::set<std::string> found{r.steps[0].effect, r.steps[1].effect};
  EXPECT_TRUE(found.count("creep") && found.count("time_delay")) << r.steps[0].effect << ", " << r.steps[1].effect;
  EXPECT_LT(r.steps[1].gap_deg, r.steps[0].gap_deg);
}

TEST(GapSignals, LocalSlopeOfARampIsItsSlope) {
  Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(101, 0.0, 10.0);  // 0.1 per sample
  const Eigen::VectorXd s = pof::gap::local_slope(x, 0.005, 10);
  for (Eigen::Index i = 0; i < x.size(); ++i) EXPECT_NEAR(s(i), 20.0, 1e-9);
}

// The joint behind a reference seen through belt play (apply_backlash): a ramp at constant
// speed into a hold and out of it the other way, then a gait whose turns are smooth. The reference
// is the joint through the play operator, with potentiometer noise, read as `pof gap` reads it.
TEST(GapSignals, BacklashGivesTheJointBackThroughItsTurns) {
  constexpr double kDt = 0.005, kPlay = 0.8, kPi = std::numbers::pi;
  std::vector<double> joint;
  auto hold = [&](double s) { for (int i = 0; i < static_cast<int>(s / kDt); ++i) joint.push_back(joint.back()); };
  auto ramp = [&](double to, double speed) {
    const double from = joint.back(), dir = to > from ? 1 : -1;
    for (double x = from + dir * speed * kDt; dir * (to - x) > 0; x += dir * speed * kDt) joint.push_back(x);
    joint.push_back(to);
  };
  joint.push_back(0.0);
  hold(2), ramp(40, 8), hold(4), ramp(0, 8), hold(3);
  const std::size_t gait_from = joint.size();
  for (int i = 1; i <= static_cast<int>(45 / kDt); ++i)  // 1 Hz, 0..50 deg
    joint.push_back(25 - 25 * std::cos(2 * kPi * i * kDt));
  hold(3);
  const auto n = static_cast<Eigen::Index>(joint.size());
  pof::io::Recording rec;
  rec.source = "backlash.csv";
  rec.t_s = Eigen::VectorXd::LinSpaced(n, 0, kDt * static_cast<double>(n - 1));
  rec.sensor_v = rec.reference_v = Eigen::VectorXd::Ones(n);
  rec.angle_ref_deg.resize(n);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0, 0.02);
  double y = -kPlay / 2;  // the belt as if the joint had come from below
  for (Eigen::Index i = 0; i < n; ++i) {
    y = pof::core::play_operator(y, joint[static_cast<std::size_t>(i)], kPlay / 2);
    rec.angle_ref_deg(i) = y + noise(rng);
  }
  const auto s = pof::gap::make_signals(rec);
  auto k = pof::gap::make_kinematics(s.angle, s.dt, 0.0);
  pof::gap::apply_backlash(k, kPlay, s.dt);
  // From the first movement on (before it the side of the band is unknown).
  double sq = 0, worst_turn = 0;
  Eigen::Index counted = 0, worst_at = 0;
  for (Eigen::Index i = static_cast<Eigen::Index>(2 / kDt); i < n; ++i) {
    const double e = k.angle(i) - joint[static_cast<std::size_t>(i)];
    sq += e * e, ++counted;
    // The gait's turns after its first, 0.25 s in (that one leaves the hold unlike the ramp came
    // into it: see apply_backlash).
    if (static_cast<std::size_t>(i) >= gait_from + 50 && std::abs(e) > worst_turn)
      worst_turn = std::abs(e), worst_at = i;
  }
  // Measured: 0.017 deg RMS and 0.13 deg at worst (one noisy turn). The earlier rule, a crossing
  // at the departure's mean speed: 0.097 deg and 0.82 deg.
  EXPECT_LT(std::sqrt(sq / static_cast<double>(counted)), 0.03);
  EXPECT_LT(worst_turn, 0.2) << "at " << static_cast<double>(worst_at) * kDt << " s";
}

// The folds' blocks are dealt out in turn over the whole session, so every fold's training blocks
// hold every kind of movement it has; block_s = 0 gives one contiguous block per fold.
TEST(GapFolds, BlocksAreDealtOutInTurnAndTileTheRecording) {
  pof::gap::SynthConfig cfg;
  cfg.short_protocol = true;
  cfg.extra_seconds = 60;
  const auto rec = pof::gap::synthesise(cfg, 3);
  const double duration = rec.t_s(rec.size() - 1) - rec.t_s(0);
  for (const double block_s : {0.0, 20.0}) {
    pof::gap::Options opt;
    opt.block_s = block_s;
    opt.max_steps = 0;
    const auto r = pof::gap::analyse(rec, opt);
    const auto& folds = r.recording.at("fold_blocks_s");
    ASSERT_EQ(folds.size(), 5u);
    std::vector<std::pair<double, double>> blocks;  // in the order they were dealt
    for (std::size_t j = 0;; ++j) {
      const auto& fold = folds[j % 5];
      if (j / 5 >= fold.size()) break;
      blocks.emplace_back(fold[j / 5][0].get<double>(), fold[j / 5][1].get<double>());
    }
    std::size_t total = 0;
    for (const auto& f : folds) total += f.size();
    ASSERT_EQ(blocks.size(), total) << "blocks not dealt in turn";
    const auto expected = block_s > 0 ? static_cast<std::size_t>(std::lround(duration / (5 * block_s))) : 1u;
    EXPECT_EQ(folds[0].size(), expected);
    EXPECT_NEAR(blocks.front().first, 0.0, 1e-9);
    EXPECT_NEAR(blocks.back().second, duration, 0.01);
    for (std::size_t j = 1; j < blocks.size(); ++j)
      EXPECT_NEAR(blocks[j].first, blocks[j - 1].second + 0.005, 1e-6) << "block " << j << " does not follow its predecessor";
  }
}

// The running-sum slope against the least-squares formula on noise, over 3 resync periods: centred
// wherever the window fits, and within half of either end the first (last) full window's slope.
TEST(GapSignals, LocalSlopeIsTheLeastSquaresSlopeOfTheNearestFullWindow) {
  std::mt19937_64 rng(9);
  std::normal_distribution<double> step(0, 0.3);
  Eigen::VectorXd x(13000);
  double walk = 40;
  for (Eigen::Index i = 0; i < x.size(); ++i) x(i) = walk += step(rng);
  const Eigen::Index n = x.size();
  for (const Eigen::Index half : {1, 10, 25}) {
    const Eigen::VectorXd s = pof::gap::local_slope(x, 0.005, half);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Index c = std::clamp(i, half, n - 1 - half);  // the window's centre
      double num = 0, den = 0;
      for (Eigen::Index k = -half; k <= half; ++k) num += static_cast<double>(k) * x(c + k), den += static_cast<double>(k * k);
      // deg/s: the running sums round to ~1e-9 deg/s on this 40 +- 30 deg walk (a potentiometer's
      // noise alone gives ~0.3 deg/s)
      ASSERT_NEAR(s(i), num / den / 0.005, 1e-7) << "half " << half << ", scan " << i;
    }
  }
}

// Differentiated twice (the acceleration column), potentiometer-like noise stays as small at the
// recording's ends as inside it. A window shrunk to stay centred differentiated two scans' noise
// at the ends: 10-30 times the drive's largest acceleration there on a blind recording, enough to
// pull the acceleration term's least-squares fit.
TEST(GapSignals, TwiceDifferentiatedNoiseIsNoLargerAtTheEnds) {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> noise(0, 0.01);  // deg, after the +-25 ms smoothing
  Eigen::VectorXd x(4000);
  for (Eigen::Index i = 0; i < x.size(); ++i) x(i) = 30 + noise(rng);
  const Eigen::VectorXd acc = pof::gap::local_slope(pof::gap::local_slope(x, 0.005, 10), 0.005, 10);
  const double inside = acc.segment(100, x.size() - 200).cwiseAbs().maxCoeff();
  const double ends = std::max(acc.head(20).cwiseAbs().maxCoeff(), acc.tail(20).cwiseAbs().maxCoeff());
  EXPECT_LE(ends, inside) << "largest |acceleration| at the ends " << ends << ", inside " << inside;
}

TEST(GapSignals, ShortRecordingIsADataError) {
  pof::io::Recording rec;
  rec.source = "tiny.csv";
  rec.t_s = Eigen::VectorXd::LinSpaced(50, 0, 0.245);
  rec.sensor_v = rec.reference_v = rec.angle_ref_deg = Eigen::VectorXd::Ones(50);
  try {
    (void)pof::gap::analyse(rec);
    FAIL() << "no error";
  } catch (const pof::DataError& e) {
    EXPECT_NE(std::string(e.what()).find("tiny.csv"), std::string::npos);
  }
}

TEST(GapSignals, NonConstantRateNamesTheRow) {
  pof::gap::SynthConfig cfg;
  cfg.short_protocol = true;
  auto rec = pof::gap::synthesise(cfg, 1);
  rec.source = "gappy.csv";
  rec.t_s.tail(100).array() += 1.0;  // a one-second gap
  try {
    (void)pof::gap::analyse(rec);
    FAIL() << "no error";
  } catch (const pof::DataError& e) {
    EXPECT_NE(std::string(e.what()).find("gappy.csv: data row"), std::string::npos) << e.what();
  }
}
