#pragma once
// The effect vocabulary of the model-gap workflow (docs/gap.md) mapped onto scenario switches, so a
// test harness can hide an effect by name: `*effect_switch(s, "creep") = true;` then set its
// parameters in the named section (scenario.hpp).
#include <array>
#include <string_view>

#include "pof/sim/scenario.hpp"

namespace pof::sim {

inline constexpr std::array<std::string_view, 9> kGapEffectIds{
    "static_nonlinearity", "drift", "creep", "rate_dependent_hysteresis", "acceleration_dependence",
    "time_delay", "backlash", "source_power_coupling", "periodic_interference"};

/// The `enabled` flag of the effect with that identifier, or nullptr for an unknown one.
/// time_delay delays daq.time_delay.channel (the sensor by default); source_power_coupling is only
/// visible when the source power varies (light.wander or light.steps enabled).
inline bool* effect_switch(Scenario& s, std::string_view id) {
  if (id == "static_nonlinearity") return &s.sensor.static_nonlinearity.enabled;
  if (id == "drift") return &s.sensor.drift.enabled;
  if (id == "creep") return &s.sensor.creep.enabled;
  if (id == "rate_dependent_hysteresis") return &s.sensor.rate_dependent_hysteresis.enabled;
  if (id == "acceleration_dependence") return &s.sensor.acceleration_dependence.enabled;
  if (id == "time_delay") return &s.daq.time_delay.enabled;
  if (id == "backlash") return &s.knee.backlash.enabled;
  if (id == "source_power_coupling") return &s.light.source_power_coupling.enabled;
  if (id == "periodic_interference") return &s.daq.periodic_interference.enabled;
  return nullptr;
}

/// Switches every optional effect off (the paper's hysteresis model, f1-f4, stays on): the
/// baseline `pof gap` starts from. Noise and quantisation are left as they are.
inline void disable_all_effects(Scenario& s) {
  for (auto id : kGapEffectIds) *effect_switch(s, id) = false;
  s.knee.vibration.enabled = false;
  s.knee.potentiometer.linearity.enabled = false;
  s.light.wander.enabled = false;
  s.light.steps.enabled = false;
}

}  // namespace pof::sim
