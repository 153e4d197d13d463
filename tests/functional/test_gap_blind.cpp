// The blind test of `pof gap` (docs/gap.md) on the physics simulator: a hidden draw (none, one or two effects with
// random magnitudes, per seed), a CSV file written by the harness, `pof gap`'s analysis of that file
// alone, and only then the comparison. Short sessions (~5 min of data) keep each case to seconds;
// the statistics over >= 100 recordings are bench_gap's (BENCHMARKS.md). The tests of one
// benchmark recording (the bend lag named in the baseline beside either structure, a relaxation
// spectrum named once, an acceleration term without a delay beside it, a slow leftover that is no
// light source's coupling, a Preisach fibre's first loading) run its full session. The last test
// runs core::fit_dynamic (the dynamic baseline's fit) alone on the short session.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "pof/core/dynamic_fit.hpp"
#include "pof/testing/gap_blind.hpp"

namespace {

std::filesystem::path workdir() {
  auto d = std::filesystem::path(POF_BINARY_DIR) / "tests/work/gap_blind";
  std::filesystem::create_directories(d);
  return d;
}

// Whether gap.json says that effects a and b are indistinguishable on its recording, with what
// would tell them apart (docs/gap.md, section 4, "Said, not hidden").
bool said(const nlohmann::json& gap, const std::string& a, const std::string& b) {
  for (const auto& d : gap.at("indistinguishable")) {
    const auto& e = d.at("effects");
    if (e.size() == 2 && e[0] == a && e[1] == b && !d.at("tells_apart").get<std::string>().empty()) return true;
  }
  return false;
}

std::string names(const std::vector<pof::gap::blind::Hidden>& h) {
  std::string s;
  for (const auto& x : h) s += x.effect + " " + x.truth.dump() + "; ";
  return s.empty() ? "none" : s;
}

void check(std::uint64_t seed, int count, double dynamic_share = 0.0, const pof::gap::Options& opt = {}) {
  const auto t = pof::gap::blind::run_trial(seed, count, true, workdir(), opt, 0.3, dynamic_share);
  std::string found;
  for (const auto& st : t.gap.at("steps"))  // effect, parameters and reduction of each accepted step
    found += st.at("effect").get<std::string>() + " " + st.at("parameters").dump() + " (" +
             std::to_string(st.at("evidence").at("reduction_pct").get<double>()) + " %) ";
  const std::string what = "seed " + std::to_string(seed) + ": hidden " + names(t.hidden) + " found " + found;
  std::cout << what << "gap " << t.baseline_gap_deg << " -> " << t.final_gap_deg << " deg\n";
  SCOPED_TRACE(what);
  // A sensor of the dynamic model's kind with nothing hidden is the dynamic model's to explain
  // (docs/gap.md, section 1); a paper-structure one keeps the paper structure.
  const std::string chosen = t.gap.at("baseline").at("choice").at("chosen").get<std::string>();
  if (t.dynamic.is_null() || t.hidden.empty()) {
    EXPECT_EQ(chosen, t.dynamic.is_null() ? "paper" : "dynamic") << t.gap.at("baseline").at("choice").dump();
  }
  EXPECT_EQ(t.hits(), static_cast<int>(t.hidden.size()));
  EXPECT_EQ(t.false_finds(), 0);
  // The >= 50 % target is on the median over the benchmark's recordings (BENCHMARKS.md); one
  // recording must at least shrink by a third (an acceleration term is estimated from the
  // potentiometer and leaves part of itself behind: docs/gap.md, limitations).
  if (!t.hidden.empty()) EXPECT_GE(t.shrink(), 0.33) << t.baseline_gap_deg << " -> " << t.final_gap_deg;
  else EXPECT_EQ(t.final_gap_deg, t.baseline_gap_deg);
  std::filesystem::remove(t.csv);
}

}  // namespace

TEST(GapBlind, NothingHidden) { check(1001, 0); }
TEST(GapBlind, OneEffectA) { check(1002, 1); }
TEST(GapBlind, OneEffectB) { check(1003, 1); }
TEST(GapBlind, OneEffectC) { check(1004, 1); }
TEST(GapBlind, TwoEffects) { check(1005, 2); }
// Sensors of the dynamic model's kind (draw_dynamic_sensor): memory hysteresis, Prony relaxation,
// maybe a bend lag and a bowed curve, instead of the paper's steps.
TEST(GapBlind, DynamicSensorNothingHidden) { check(1006, 0, 1.0); }
// Seed 1007's fibre lags the joint by 58 ms: beside its rate-dependent hysteresis an acceleration
// term is named, the lag's second order (covered by the harness: tests/generators/src/gap_blind.cpp).
TEST(GapBlind, DynamicSensorOneEffect) { check(1007, 1, 1.0); }

// A delay of the angle on a fibre of the dynamic model's kind without a bend lag of its own: the
// dynamic fit takes the delay as its bend lag (the two look alike at these speeds) and fits it to
// the noise, so the search has nothing left and the baseline must name it (gap.json in_baseline).
// Blind seed 273 of the benchmark (a full session: a 56 ms delay fitted as a 67 ms lag).
TEST(GapBlind, DynamicBaselineNamesTheLateAngle) {
  const auto t = pof::gap::blind::run_trial(273, 1, false, workdir(), {}, 0.3, 0.5);
  SCOPED_TRACE("hidden " + names(t.hidden) + ", in the baseline " + t.gap.at("in_baseline").dump());
  ASSERT_EQ(t.hidden.size(), 1U);
  ASSERT_EQ(t.hidden[0].effect, "time_delay");
  EXPECT_EQ(t.gap.at("baseline").at("choice").at("chosen").get<std::string>(), "dynamic");
  ASSERT_EQ(t.gap.at("in_baseline").size(), 1U);
  const double truth_ms = 1e3 * t.hidden[0].truth.at("delay_s").get<double>();
  EXPECT_NEAR(t.gap.at("in_baseline")[0].at("parameters").at("delay_ms").get<double>(), truth_ms, 0.5 * truth_ms);
  EXPECT_EQ(t.hits(), 1);
  EXPECT_EQ(t.false_finds(), 0);
  // The lag is the structure's: model.toml must not apply a delay on top of it.
  EXPECT_EQ(t.gap.at("model").at("delay_s").get<double>(), 0.0);
  // And the report says that this recording does not tell the delay from the fibre's bend lag,
  // and what would (docs/gap.md, section 4, "Said, not hidden").
  EXPECT_TRUE(said(t.gap, "time_delay", "bend lag")) << t.gap.at("indistinguishable").dump();
  std::filesystem::remove(t.csv);
}

// Its control: the same sensor and lag-free fibre (drawn before the effects) with nothing hidden
// takes the dynamic baseline and names nothing late.
TEST(GapBlind, DynamicBaselineNamesNoLateAngleWhereThereIsNone) {
  const auto t = pof::gap::blind::run_trial(273, 0, false, workdir(), {}, 0.3, 0.5);
  SCOPED_TRACE("in the baseline " + t.gap.at("in_baseline").dump());
  EXPECT_EQ(t.gap.at("baseline").at("choice").at("chosen").get<std::string>(), "dynamic");
  EXPECT_TRUE(t.gap.at("in_baseline").empty());
  EXPECT_EQ(t.false_finds(), 0);
  EXPECT_FALSE(said(t.gap, "time_delay", "bend lag")) << "no lag named, none to confuse with a delay";
  // Its fit has a rate gain (-1 s/rad, 5 % of the held-out error) that the opening's own shape does
  // not replace: no speed-dependent opening is said either.
  EXPECT_FALSE(said(t.gap, "rate_dependent_hysteresis", "rate gain")) << t.gap.at("indistinguishable").dump();
  std::filesystem::remove(t.csv);
}

// A 49 ms delay of the angle on a Preisach fibre (blind seed 338 of the benchmark, a full session).
// The dynamic baseline with the memory term's relays fits it better than the paper structure, whose
// velocity-dependent branches had absorbed the lateness (it was kept there before the relay form).
// The structure's bend lag (34 ms) carries most of the lateness and the search adds a delay step on
// top: the step reports both together, the lateness a user would measure (docs/gap.md, section 1,
// "What the baseline names").
TEST(GapBlind, ALateAngleOnAPreisachFibreIsNamedWithTheBendLag) {
  const auto t = pof::gap::blind::run_trial(338, 1, false, workdir(), {}, 0.3, 1.0, 0.5);
  SCOPED_TRACE("hidden " + names(t.hidden) + ", steps " + t.gap.at("steps").dump().substr(0, 1500) +
               ", in the baseline " + t.gap.at("in_baseline").dump());
  ASSERT_EQ(t.hidden.size(), 1U);
  ASSERT_EQ(t.hidden[0].effect, "time_delay");
  ASSERT_EQ(t.dynamic.at("memory").at("family"), "preisach") << "the test needs another seed";
  EXPECT_EQ(t.gap.at("baseline").at("choice").at("chosen"), "dynamic");
  EXPECT_EQ(t.hits(), 1);
  double lateness_ms = 0;
  for (const auto& st : t.gap.at("in_baseline")) lateness_ms = st.at("parameters").at("delay_ms").get<double>();
  for (const auto& st : t.gap.at("steps"))
    if (st.at("effect") == "time_delay") {
      const auto& p = st.at("parameters");
      lateness_ms = p.value("with_bend_lag_ms", p.at("delay_ms").get<double>());
    }
  const double truth_ms = 1e3 * t.hidden[0].truth.at("delay_s").get<double>();
  EXPECT_NEAR(lateness_ms, truth_ms, 0.5 * truth_ms);
  EXPECT_LE(t.false_finds(), 1);
  std::filesystem::remove(t.csv);
}

// A rate-dependent hysteresis and an acceleration term on a Bouc-Wen fibre whose loop has a speed
// factor of its own: the dynamic fit takes the opening into its rate gain, and the search, scoring
// the effect beside the gain, names the acceleration term only. The effect's own column with the
// gain at 0 explains the residual as well, so the report says the two are indistinguishable here
// and keeps the gain (docs/gap.md, section 4, "Said, not hidden"). Blind seed 305 of the benchmark.
TEST(GapBlind, ALoopThatChangesWithSpeedIsSaidAsGainOrOpening) {
  const auto t = pof::gap::blind::run_trial(305, 2, false, workdir(), {}, 0.3, 1.0, 0.5);
  SCOPED_TRACE("hidden " + names(t.hidden) + ", said " + t.gap.at("indistinguishable").dump());
  ASSERT_EQ(t.hidden.size(), 2U);
  ASSERT_TRUE(t.hidden[0].effect == "rate_dependent_hysteresis" || t.hidden[1].effect == "rate_dependent_hysteresis");
  ASSERT_EQ(t.gap.at("baseline").at("choice").at("chosen").get<std::string>(), "dynamic") << "the test needs another seed";
  EXPECT_TRUE(said(t.gap, "rate_dependent_hysteresis", "rate gain"));
  EXPECT_EQ(t.hits_or_said(), 2);
  EXPECT_EQ(t.false_finds(), 0);
  // The gain stays in the model the compensator runs; no [gap] term is added for the opening.
  for (const auto& st : t.gap.at("steps")) EXPECT_NE(st.at("effect").get<std::string>(), "rate_dependent_hysteresis");
  std::filesystem::remove(t.csv);
}

// Blind seed 232 of the benchmark (a full session, a paper-structure sensor): a creep hidden, the
// light source wandering and cancelled exactly. What the creep term leaves (its time constant
// between grid values) is slow, and so is the reference's level: the two correlated by chance and
// the light source's coupling was named (6 %). It must now also explain the residual's part faster
// than 40 s, which a chance correlation does not (docs/gap.md, section 4, "Slow random columns").
TEST(GapBlind, ASlowLeftoverIsNoLightSourceCoupling) {
  pof::gap::Options two_steps;  // the creep, then the step where the coupling was named
  two_steps.max_steps = 2;
  const auto t = pof::gap::blind::run_trial(232, 1, false, workdir(), two_steps, 0.3, 0.5);
  SCOPED_TRACE("steps " + t.gap.at("steps").dump().substr(0, 1500));
  ASSERT_EQ(t.hidden.size(), 1U);
  ASSERT_EQ(t.hidden[0].effect, "creep");
  EXPECT_EQ(t.hits(), 1);
  EXPECT_EQ(t.false_finds(), 0);
  // The case this test is for: the coupling passed the acceptance rule and was refused by its fast part.
  const auto& spc = t.gap.at("whiteness").at("last_rejected").at("all").at("source_power_coupling");
  ASSERT_TRUE(spc.contains("not_significant")) << spc.dump() << ": the test needs another seed";
  EXPECT_NE(spc.at("not_significant").get<std::string>().find("faster than 40 s"), std::string::npos);
  std::filesystem::remove(t.csv);
}

// Blind seed 213 of the benchmark (a full session, a paper-structure sensor): viscoelastic relaxation
// hidden as three Prony terms (2, 29 and 141 s). The relaxation candidate holds two time constants;
// creep then adds the third. One spectrum, one name: the step that added creep's term is named
// viscoelastic_relaxation, and its evidence keeps the term it added. The terms, applied online,
// make the compensated angle better.
TEST(GapBlind, ARelaxationSpectrumIsNamedOnce) {
  pof::gap::Options two_steps;  // the relaxation, then creep's term: the two steps the rule is about
  two_steps.max_steps = 2;
  const auto t = pof::gap::blind::run_trial(213, 1, false, workdir(), two_steps, 0.3, 0.5);
  SCOPED_TRACE("steps " + t.gap.at("steps").dump().substr(0, 1500));
  ASSERT_EQ(t.hidden.size(), 1U);
  ASSERT_EQ(t.hidden[0].effect, "viscoelastic_relaxation");
  ASSERT_EQ(t.hidden[0].truth.at("tau_s").size(), 3U);
  int relaxation = 0, creep_terms = 0;
  for (const auto& st : t.gap.at("steps")) {
    EXPECT_NE(st.at("effect").get<std::string>(), "creep");
    if (st.at("effect").get<std::string>() == "viscoelastic_relaxation") ++relaxation;
    if (st.at("evidence").value("term", "") == "creep") ++creep_terms;
  }
  EXPECT_GE(relaxation, 1);
  // The case this test is for: the search took the third time constant as creep's term.
  EXPECT_GE(creep_terms, 1) << "the search no longer adds creep's term here: the test needs another seed";
  EXPECT_EQ(t.hits(), 1);
  // Applied online, the terms help. The structure's first-order move beside them is cut to 1/16
  // here (its full step puts the branches 114 deg apart); fitted beside the whole move, the terms
  // made the held-out compensated angle worse than the baseline's (1.38 -> 1.83 deg RMSE). Fitted
  // at the structure so moved: 1.04 deg, the terms taking only the share of the relaxation the
  // baseline had not absorbed. With the structure moved on by damped Gauss-Newton beside them
  // (compensation.cpp, applied_fit): 0.37 deg (the same sensor without the relaxation: 0.35).
  const auto& comp = t.gap.at("compensated");
  EXPECT_LT(comp.at("rmse_after_deg").get<double>(), 0.5 * comp.at("rmse_before_deg").get<double>()) << comp.dump().substr(0, 600);
  std::cout << "seed 213: " << relaxation << " relaxation step(s), " << creep_terms << " of them creep's term, "
            << t.false_finds() << " false; compensated " << comp.at("rmse_before_deg").get<double>() << " -> "
            << comp.at("rmse_after_deg").get<double>() << " deg\n";
  std::filesystem::remove(t.csv);
}

// Blind seed 262 of the benchmark (a full session, a sensor of the dynamic model's kind with no rate
// dependence of its own): an acceleration dependence hidden. The dynamic fit, made without an
// acceleration term, takes a rate gain for part of it; once the term is accepted the gain is
// chosen again with the term in (search.cpp, refit_rate_gain: 0.5 -> 0 s/rad here). With the
// stale gain the search named a time_delay next for the speed-proportional residual it left.
TEST(GapBlind, AnAccelerationTermBringsNoDelayOnTheDynamicBaseline) {
  pof::gap::Options two_steps;  // the acceleration, then the step that named the delay
  two_steps.max_steps = 2;
  const auto t = pof::gap::blind::run_trial(262, 1, false, workdir(), two_steps, 0.3, 0.5);
  SCOPED_TRACE("steps " + t.gap.at("steps").dump().substr(0, 1500));
  ASSERT_EQ(t.hidden.size(), 1U);
  ASSERT_EQ(t.hidden[0].effect, "acceleration_dependence");
  ASSERT_EQ(t.gap.at("baseline").at("choice").at("chosen").get<std::string>(), "dynamic");
  EXPECT_EQ(t.hits(), 1);
  EXPECT_EQ(t.false_finds(), 0);
  for (const auto& st : t.gap.at("steps")) EXPECT_NE(st.at("effect").get<std::string>(), "time_delay");
  // The gain the fit had taken for the acceleration goes to the fibre's own, none.
  const auto& gain = t.gap.at("steps").at(0).at("evidence").at("dynamic_rate_gain_s_per_rad");
  EXPECT_GT(gain.at("before").get<double>(), 0.0);
  EXPECT_EQ(gain.at("after").get<double>(), 0.0);
  std::filesystem::remove(t.csv);
}

// The dynamic fit (core::fit_dynamic) on the short blind session, a sensor like blind seed 261's: three
// Maxwell-slip elements (the narrowest 0.95 deg), one Prony term, and the bend 64 ms behind the
// joint. Without the lag every structure with operators is non-invertible (the narrowest operator
// takes the lag's loop), so a search that settles the operator and Prony counts before the lag
// keeps what was invertible without it: the one staged pass of commit 1ea3656 gave the rate gain
// at the grid's edge (-4 s/rad, the fibre has none), a lag of 0.080 s and a held-out error of
// 0.151 deg here, failing the first three checks; the coordinate descent to a fixed point gives
// -0.5 s/rad, 0.067 s and 0.079 deg.
TEST(DynamicFitOnTheSession, ALargeBendLagIsFoundBeforeTheCountsAreSettled) {
  pof::sim::Scenario s = pof::gap::blind::base_scenario(true);
  s.sensor.hysteresis.enabled = false;  // the paper's steps off: the loop is the slip elements'
  auto& mh = s.sensor.memory_hysteresis;
  mh.enabled = true;
  mh.family = pof::sim::MemoryHysteresisFamily::kMaxwellSlip;
  mh.rate_sensitivity_s_per_rad = 0;
  mh.thresholds_deg = {0.95, 4.6, 14.4};
  mh.weights = {1, 1, 1};
  mh.amplitude_v = 0.0115;
  s.sensor.creep.enabled = true;
  s.sensor.creep.terms = {pof::sim::CreepTerm{3.5, -0.0007}};
  s.sensor.viscoelastic_lag.enabled = true;
  s.sensor.viscoelastic_lag.tau_s = 0.064;
  const pof::io::Recording rec = pof::gap::blind::simulate(s, 261);
  const Eigen::VectorXd v = rec.sensor_v.array() * (4.0 / rec.reference_v.array());
  const pof::core::DynamicFitResult fit = pof::core::fit_dynamic(rec.t_s, v, rec.angle_ref_deg);
  const pof::core::DynamicCandidate& c = fit.chosen;
  SCOPED_TRACE(std::to_string(c.n_operators) + " operators, " + std::to_string(c.n_prony) + " Prony terms, kappa " +
               std::to_string(c.rate_gain_s_per_rad) + " s/rad, lag " + std::to_string(c.bend_lag_s) + " s, CV " +
               std::to_string(c.cv_rmse_deg) + " deg");
  EXPECT_LE(std::abs(c.rate_gain_s_per_rad), 1.0);
  EXPECT_NEAR(c.bend_lag_s, 0.064, 0.1 * 0.064);
  EXPECT_LT(c.cv_rmse_deg, 0.12);
  EXPECT_GT(c.n_operators, 0);
  EXPECT_GT(c.n_prony, 0);
}

// Slow effects on their time scales (docs/gap.md, section 4): on a fibre of the dynamic model's kind
// whose physics the baseline must take first, a drift that is no straight trend (a slow wave beside
// it, as a room's regulation makes) is named a drift, and none of the fibre's own slow or memory
// physics (relaxation, memory hysteresis, a curved line) is named for it. The fibre, the drift's
// rate, the wave's amplitude (2-6 mV) and period (10-20 min) are drawn from the seed; the full
// session (~17 min, so the drift has degree 3).
TEST(GapBlind, ADriftThatIsNoTrendIsNamedADriftNotRelaxation) {
  const std::uint64_t seed = 2718;
  std::mt19937_64 rng(seed);
  pof::sim::Scenario s = pof::gap::blind::base_scenario(false);
  std::vector<std::string> covered;
  const auto fibre = pof::gap::blind::draw_dynamic_sensor(s, rng, covered);
  const auto drift = pof::gap::blind::hide(s, "drift", rng);
  s.sensor.drift.wave_v = std::uniform_real_distribution<double>(0.002, 0.006)(rng);
  s.sensor.drift.wave_period_s = std::uniform_real_distribution<double>(600.0, 1200.0)(rng);
  const pof::gap::Result r = pof::gap::analyse(pof::gap::blind::simulate(s, seed));
  std::vector<std::string> found;
  for (const auto& st : r.steps) found.push_back(st.effect);
  const std::string said = "fibre " + fibre.dump() + ", drift " + drift.truth.dump() + " wave " +
                           std::to_string(s.sensor.drift.wave_v) + " V / " +
                           std::to_string(s.sensor.drift.wave_period_s) + " s; found " +
                           r.to_json().at("steps").dump().substr(0, 1500);
  EXPECT_NE(std::find(found.begin(), found.end(), "drift"), found.end()) << said;
  for (const char* own : {"creep", "viscoelastic_relaxation", "memory_hysteresis", "static_nonlinearity"})
    EXPECT_EQ(std::find(found.begin(), found.end(), own), found.end()) << own << " named for a drift: " << said;
  EXPECT_LT(r.final_gap_deg, 0.7 * r.baseline_gap_deg) << said;
}

// Said, not hidden (docs/gap.md, section 4): a belt's play of about 2 deg (drawn 1.5-2.5 deg)
// between the joint and the potentiometer on a Bouc-Wen fibre with a bend lag, whose loop stop
// operators take in part (the dynamic baseline's, or a memory_hysteresis term's on the paper
// structure: on this draw the latter): how the loop splits between a dead band in the
// reference and a play in the fibre is said to be undetermined here, with the recording that would
// tell, and the widths said hold the one named (none: 0). (A play of 0.73 deg, seed 3141 with the
// harness's 0.5-2 deg, was named and its width determined: nothing to say.) The short session.
TEST(GapBlind, ADeadBandBesideAFibresPlayIsSaidToBeUndetermined) {
  const std::uint64_t seed = 3141;
  std::mt19937_64 rng(seed);
  pof::sim::Scenario s = pof::gap::blind::base_scenario(true);
  s.sensor.hysteresis.enabled = false;
  auto& mh = s.sensor.memory_hysteresis;
  mh.enabled = true;
  mh.family = pof::sim::MemoryHysteresisFamily::kBoucWen;
  mh.amplitude_v = 0.027;
  mh.width_deg = 12.0;
  s.sensor.viscoelastic_lag.enabled = true;
  s.sensor.viscoelastic_lag.tau_s = 0.08;
  s.knee.backlash.enabled = true;
  s.knee.backlash.width_deg = std::uniform_real_distribution<double>(1.5, 2.5)(rng);
  const std::string play = std::to_string(s.knee.backlash.width_deg) + " deg";
  const pof::gap::Result r = pof::gap::analyse(pof::gap::blind::simulate(s, seed));
  const nlohmann::json g = r.to_json();
  SCOPED_TRACE("play " + play + "; steps " + g.at("steps").dump().substr(0, 600) + "; said " +
               g.at("indistinguishable").dump());
  ASSERT_TRUE(said(g, "backlash", "memory_hysteresis"));
  double named = 0;
  for (const auto& st : r.steps)
    if (st.effect == "backlash") named = st.parameters.at("width_deg").get<double>();
  for (const auto& d : g.at("indistinguishable"))
    if (d.at("effects")[0] == "backlash") {
      EXPECT_LE(d.at("backlash_width_range_deg")[0].get<double>(), named + 1e-9);
      EXPECT_GE(d.at("backlash_width_range_deg")[1].get<double>(), named - 1e-9);
    }
}

// Blind seed 313 of the benchmark (a full session): a Preisach loop at 33 deg (+-10 deg) and a
// 12.5 ms delay of the angle. The dynamic baseline's stop operators cannot draw a loop at a fixed
// angle; what they left (0.27 deg held out) hid the delay (3.4 %, below the rule). The memory term's
// relay form takes the loop, the delay is named under it, and the compensator, running the same
// relays, ends within 1.5x of the forward gap (docs/gap.md, section 3, "A loop at a fixed angle").
TEST(GapBlind, APreisachLoopIsDrawnByRelaysAndTheDelayUnderItNamed) {
  const auto t = pof::gap::blind::run_trial(313, 1, false, workdir(), {}, 0.3, 1.0, 0.5);
  SCOPED_TRACE("steps " + t.gap.at("steps").dump().substr(0, 1500));
  ASSERT_EQ(t.dynamic.at("memory").at("family"), "preisach") << "the test needs another seed";
  ASSERT_EQ(names(t.hidden).rfind("time_delay", 0), 0u) << names(t.hidden);
  EXPECT_EQ(t.gap.at("baseline").at("choice").at("chosen"), "dynamic");
  double relay_width = 0, delay_ms = 0;
  for (const auto& st : t.gap.at("steps")) {
    if (st.at("effect") == "memory_hysteresis") relay_width = st.at("parameters").value("relay_half_width_deg", 0.0);
    if (st.at("effect") == "time_delay") delay_ms = st.at("parameters").at("delay_ms").get<double>();
  }
  EXPECT_GE(relay_width, 4.0);
  EXPECT_GT(delay_ms, 4.0);
  EXPECT_LT(t.final_gap_deg, 0.6 * t.baseline_gap_deg);
  const auto& c = t.gap.at("compensated");
  EXPECT_LT(c.at("rmse_after_deg").get<double>(), 0.6 * c.at("rmse_before_deg").get<double>());
  const auto& av = t.gap.at("angle_vs_forward");
  EXPECT_LT(av.at("angle_rmse_deg").get<double>(), 1.5 * av.at("forward_gap_deg").get<double>());
  std::filesystem::remove(t.csv);
}

// Blind seed 366 of the benchmark (a full session, an effect-free Preisach fibre: a relay density
// the dynamic model does not contain). The paper structure with static_nonlinearity and
// memory_hysteresis left a change of the output early in the session, while the angle first went
// through its range, and a drift was named for it: a false discovery (still named with the fibre's
// power-law relaxation switched off in the draw; gone when the first 198 s, until the angle first
// reached its top, are cut from the recording). A first loading's columns explain it as well, so
// it is said, not named (docs/gap.md, section 4, "First loading or drift").
TEST(GapBlind, APreisachFibresFirstLoadingIsNoDrift) {
  const auto t = pof::gap::blind::run_trial(366, 0, false, workdir(), {}, 0.3, 1.0, 0.5);
  SCOPED_TRACE("steps " + t.gap.at("steps").dump().substr(0, 1500));
  ASSERT_EQ(t.dynamic.at("memory").at("family"), "preisach") << "the test needs another seed";
  EXPECT_EQ(std::count(t.found.begin(), t.found.end(), "drift"), 0);
  EXPECT_EQ(t.false_finds(), 0);
  std::filesystem::remove(t.csv);
}
