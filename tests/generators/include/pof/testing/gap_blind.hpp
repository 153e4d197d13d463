#pragma once
// The blind test harness of `pof gap` (docs/gap.md): draw an effect (or none, or two) and its magnitude at random,
// generate a recording with the physics simulator (pof_sim), write it to a CSV file, run
// the gap workflow on that file alone, and only then compare with what was hidden.
#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pof/gap/gap.hpp"
#include "pof/io/recording.hpp"
#include "pof/sim/scenario.hpp"

namespace pof::gap::blind {

/// One hidden effect: its identifier and the simulator parameters it was given.
struct Hidden {
  std::string effect;
  nlohmann::json truth;  // e.g. {"tau_s": 5.1, "gain_v_per_deg": -0.001}
};

/// The session every blind recording starts from: builtin "paper" scenario (the paper's model,
/// mild noise, 12-bit DAQ) with all optional effects off, a wandering and stepping light source
/// (cancelled exactly by the reference unless source_power_coupling is hidden), the quasi-static
/// test up and back down, constant-velocity cycles and gait-like cycles. `short_session` keeps
/// ~5 min (tests); otherwise ~17 min (benchmark).
sim::Scenario base_scenario(bool short_session);

/// Draws the parameters of `effect` at random in a range where it matters (about 1.5x to 10x the
/// noise floor of the base session) and switches it on in `s`.
Hidden hide(sim::Scenario& s, const std::string& effect, std::mt19937_64& rng);

/// Draws `count` distinct effects at random, none of `exclude`, and hides them.
std::vector<Hidden> hide_random(sim::Scenario& s, int count, std::mt19937_64& rng,
                                const std::vector<std::string>& exclude = {});

/// A sensor whose physics is the dynamic model's instead of the paper's steps (docs/gap.md,
/// section 6): the paper's f1-f4 off; a continuous hysteresis with memory (Maxwell-slip or Bouc-Wen,
/// half-height ~1-2.5 deg, its width changing with speed or not); one or two Prony relaxation terms;
/// half the time a bend lag of the fibre behind the joint and half the time a bowed quasi-static
/// curve. The simulator's families are not the dynamic model's own (Bouc-Wen is no stop operator,
/// its speed factor is exponential): a sensor of the dynamic model's kind, not of its equations.
/// Returns the draw; `covered` receives the effects this physics already is (memory hysteresis,
/// relaxation, a curved line, and time_delay for a bend lag: the sensor sees the angle late),
/// which are then not hidden on top (the simulator has one switch for each). run_trial adds, after
/// the draw, acceleration_dependence for a bend lag (the lag's second order).
nlohmann::json draw_dynamic_sensor(sim::Scenario& s, std::mt19937_64& rng, std::vector<std::string>& covered);

/// A sensor of the paper's structure with its own coefficients: c1, c2, c9, c10 and c3-c6 of each
/// direction each within +-spread of table 2, c7 and c8 through the chain's departure from identity
/// at zero hysteresis (also +-spread; see gap_blind.cpp), redrawn until the output fits the DAQ's
/// +-5 V over 0-90 deg.
core::ModelCoefficients draw_sensor(std::mt19937_64& rng, double spread);

/// Runs the simulator to the end of the trajectory (or duration_s) into a Recording.
io::Recording simulate(const sim::Scenario& s, std::uint64_t seed);

struct Trial {
  std::uint64_t seed = 0;
  core::ModelCoefficients sensor;   // the sensor's own coefficients (draw_sensor)
  nlohmann::json dynamic;           // the dynamic sensor's draw (draw_dynamic_sensor), null for a paper-structure one
  std::vector<std::string> covered;  // the effects the dynamic sensor's own physics is (draw_dynamic_sensor)
  std::vector<Hidden> hidden;
  std::vector<std::string> found;   // accepted effects, in order
  std::vector<std::string> said;    // effects the report names as indistinguishable from another here (gap.json)
  double baseline_gap_deg = 0, final_gap_deg = 0;
  double analysis_s = 0;
  // The compensator's angle (gap.json's `compensated`: the baseline's, and block by block the found
  // model's fitted on the other blocks) against the simulated joint's true angle, which no reference
  // noise reaches [deg RMSE]; 0 when the compensator could not run.
  double truth_before_deg = 0, truth_after_deg = 0;
  std::string csv;                  // the file the workflow saw
  nlohmann::json gap;               // gap.json of the run

  [[nodiscard]] bool correct() const;        // every hidden effect found, nothing else
  [[nodiscard]] int hits() const;            // hidden effects that were found
  [[nodiscard]] int hits_or_said() const;    // ... or named as one of a pair the report says it cannot tell apart
  [[nodiscard]] int false_finds() const;     // found effects that were neither hidden nor the sensor's own physics (covered)
  [[nodiscard]] double shrink() const { return baseline_gap_deg > 0 ? 1.0 - final_gap_deg / baseline_gap_deg : 0.0; }
};

/// The baseline compensator's angle RMSE against the reference [deg] (gap.json's
/// compensated.rmse_before_deg) on the recording run_trial draws for `seed`, drawn with the same
/// sensor and none of its hidden effects: what a perfect model of those effects would leave (the
/// sensor's noise, the structure's own error, the reference's noise), so 1 - this / the trial's
/// rmse_before_deg is the most its compensated reduction can be. Its noise is another draw of the
/// same level. The CSV file is written to dir and removed.
double effect_free_rmse(std::uint64_t seed, bool short_session, const std::filesystem::path& dir,
                        double sensor_spread = 0.3, double dynamic_share = 0.0, double other_family_share = 0.0);

/// One blind trial: a sensor (draw_sensor with sensor_spread; 0 = the paper's table 2), with
/// probability dynamic_share one of the dynamic model's kind (draw_dynamic_sensor, on top of the
/// drawn f5), and `count` random effects (0, 1, 2, ...) drawn with `seed`, the recording written to
/// dir/blind_<seed>.csv, read back and analysed with only the file. The sensor's kind is drawn
/// from a stream of its own, so a paper-structure sensor and its effects are the same draw for a
/// seed whatever the share. With probability other_family_share a dynamic-kind sensor's memory is a
/// Preisach relay density and its relaxation a power law (families the dynamic model does not
/// contain; its bend lag and bow stay), from a stream of its own again: 0 draws every sensor as
/// before.
Trial run_trial(std::uint64_t seed, int count, bool short_session, const std::filesystem::path& dir,
                const Options& opt = {}, double sensor_spread = 0.3, double dynamic_share = 0.0,
                double other_family_share = 0.0);

}  // namespace pof::gap::blind
