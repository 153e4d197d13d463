#pragma once
// Synthetic recordings with hidden effects, for the unit tests and the blind benchmark: the
// calibration protocol (quasi-static steps, constant-velocity cycles at table-1 velocities) run
// through the paper model (model_voltage), with each effect of pof/core/effects.hpp injected in a
// physical form written independently of `pof gap`'s columns.
// This is the test generator for the unit tests that must not depend on the simulator.
#include <cstdint>
#include <map>
#include <random>
#include <string>

#include "pof/core/model.hpp"
#include "pof/io/recording.hpp"

namespace pof::gap {

struct SynthConfig {
  double rate_hz = 200;
  int cycles_per_velocity = 1;
  bool short_protocol = false;       // fewer velocities and steps (unit tests: ~3 min)
  double noise_v = 0.002;            // sensor noise [V] (white, Gaussian)
  double pot_noise_deg = 0.03;       // reference angle noise [deg]
  double reference_level_v = 4.0;
  double reference_wander = 0.0;     // relative light-source wander (cancelled unless coupled)
  double extra_seconds = 0;          // gait-like variable-velocity movement appended
  /// Hidden effects: identifier -> magnitude in the effect's natural unit:
  ///  static_nonlinearity [deg at the range ends], drift [deg over the recording],
  ///  creep [gain, fraction of the angle step; tau fixed by creep_tau_s],
  ///  rate_dependent_hysteresis [V, +-A (1-exp(-w/0.1)) sin(pi angle/90)], acceleration_dependence [deg per rad/s^2],
  ///  time_delay [s], backlash [deg], source_power_coupling [fraction of power not cancelled],
  ///  periodic_interference [V amplitude at interference_hz], memory_hysteresis [V half-height of an
  ///  exponential-approach hysteron, 5 deg], viscoelastic_relaxation [total gain of two Prony terms,
  ///  1.5 s and 40 s].
  std::map<std::string, double> effects;
  double creep_tau_s = 4.0;
  /// The sensor's own table-2 coefficients (every real sensor differs from the paper's).
  core::ModelCoefficients model = core::paper_coefficients();
  double interference_hz = 50.0;
};

/// Deterministic for a given config and seed.
io::Recording synthesise(const SynthConfig& cfg, std::uint64_t seed);

/// A magnitude for effect `name` drawn at random in a range where it matters (1.5x-6x the noise).
double draw_magnitude(const std::string& name, std::mt19937_64& rng);

}  // namespace pof::gap
