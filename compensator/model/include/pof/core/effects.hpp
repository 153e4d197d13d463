#pragma once
// The catalogue of physical effects a POF knee sensor, its belt drive and its DAQ can show beyond
// the paper's model (Leal-Junior et al. 2017, table 2): listed once, here. The simulator switches
// them on by this identifier (pof/sim/effects.hpp), `pof gap` searches for them (compensator/gap/effects/, one file
// each: columns, grid, parameters) and the compensator applies what `pof gap` found
// (gap_terms.hpp). docs/gap.md gives each effect's physical form.
#include <array>
#include <optional>
#include <string_view>

namespace pof::core {

enum class Effect : int {
  kStaticNonlinearity,      // the quasi-static line bends: angle error polynomial in the angle
  kDrift,                   // an offset that grows with time (source ageing, temperature)
  kCreep,                   // one viscoelastic relaxation time (standard linear solid)
  kRateDependentHysteresis, // a loop opening that grows with speed and vanishes in holds
  kAccelerationDependence,  // a term in the angular acceleration (inertia of the fibre sleeve)
  kTimeDelay,               // the sensor channel sees the angle late (filters, DAQ buffering)
  kBacklash,                // play in the belt between the joint and the potentiometer
  kSourcePowerCoupling,     // imperfect cancellation of the source power by the reference fibre
  kPeriodicInterference,    // mains or motor pick-up at one frequency
  kMemoryHysteresis,        // rate-independent loop with memory: persists through holds, minor loops
  kViscoelasticRelaxation,  // relaxation over several time constants (a Prony series)
};

inline constexpr std::size_t kEffectCount = 11;

/// The identifiers used in files, reports and on the command line (docs/gap.md), in enum order.
inline constexpr std::array<std::string_view, kEffectCount> kEffectIds{
    "static_nonlinearity", "drift",           "creep",
    "rate_dependent_hysteresis", "acceleration_dependence", "time_delay",
    "backlash",            "source_power_coupling", "periodic_interference",
    "memory_hysteresis",   "viscoelastic_relaxation"};

inline constexpr std::array<Effect, kEffectCount> kAllEffects{
    Effect::kStaticNonlinearity, Effect::kDrift,           Effect::kCreep,
    Effect::kRateDependentHysteresis, Effect::kAccelerationDependence, Effect::kTimeDelay,
    Effect::kBacklash,           Effect::kSourcePowerCoupling, Effect::kPeriodicInterference,
    Effect::kMemoryHysteresis,   Effect::kViscoelasticRelaxation};

constexpr std::string_view to_string(Effect e) { return kEffectIds[static_cast<std::size_t>(e)]; }

constexpr std::optional<Effect> effect_of(std::string_view id) {
  for (std::size_t i = 0; i < kEffectCount; ++i)
    if (kEffectIds[i] == id) return kAllEffects[i];
  return std::nullopt;
}

/// The angle of static_nonlinearity's polynomial, u = (angle - 45) / 45: -1 at 0 deg, +1 at 90 deg.
/// One definition for the simulator, `pof gap` and the compensator, since a static_nonlinearity
/// term's coefficients mean something only on this u (docs/calibration.md, "[gap]").
constexpr double static_nonlinearity_u(double angle_deg) { return (angle_deg - 45.0) / 45.0; }

}  // namespace pof::core
