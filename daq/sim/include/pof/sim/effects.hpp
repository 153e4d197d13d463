#pragma once
// The effect catalogue (pof/core/effects.hpp, shared with `pof gap` and the compensator) mapped onto
// scenario switches, so a test harness can hide an effect by name: `*effect_switch(s, "creep") =
// true;` then set its parameters in the named section (scenario.hpp).
#include <string_view>

#include "pof/core/effects.hpp"
#include "pof/sim/scenario.hpp"

namespace pof::sim {

/// The `enabled` flag of an effect. time_delay delays daq.time_delay.channel (the sensor by
/// default); source_power_coupling is only visible when the source power varies (light.wander or
/// light.steps enabled). creep and viscoelastic_relaxation are both sensor.creep: one Prony term,
/// or several spread over decades (the harness sets sensor.creep.terms).
inline bool& effect_switch(Scenario& s, core::Effect e) {
  switch (e) {  // -Wswitch: an effect added to the catalogue must be given a switch here
    case core::Effect::kStaticNonlinearity: return s.sensor.static_nonlinearity.enabled;
    case core::Effect::kDrift: return s.sensor.drift.enabled;
    case core::Effect::kCreep: return s.sensor.creep.enabled;
    case core::Effect::kViscoelasticRelaxation: return s.sensor.creep.enabled;
    case core::Effect::kRateDependentHysteresis: return s.sensor.rate_dependent_hysteresis.enabled;
    case core::Effect::kAccelerationDependence: return s.sensor.acceleration_dependence.enabled;
    case core::Effect::kTimeDelay: return s.daq.time_delay.enabled;
    case core::Effect::kBacklash: return s.knee.backlash.enabled;
    case core::Effect::kSourcePowerCoupling: return s.light.source_power_coupling.enabled;
    case core::Effect::kPeriodicInterference: return s.daq.periodic_interference.enabled;
    case core::Effect::kMemoryHysteresis: return s.sensor.memory_hysteresis.enabled;
  }
  return s.sensor.drift.enabled;  // unreachable: every enumerator is handled above
}

/// The same by identifier, or nullptr for an unknown one.
inline bool* effect_switch(Scenario& s, std::string_view id) {
  const auto e = core::effect_of(id);
  return e ? &effect_switch(s, *e) : nullptr;
}

/// Switches every optional effect off (the paper's hysteresis model, f1-f4, stays on): the
/// baseline `pof gap` starts from. Noise and quantisation are left as they are.
inline void disable_all_effects(Scenario& s) {
  for (core::Effect e : core::kAllEffects) effect_switch(s, e) = false;
  s.sensor.viscoelastic_lag.enabled = false;
  s.knee.vibration.enabled = false;
  s.knee.potentiometer.linearity.enabled = false;
  s.light.wander.enabled = false;
  s.light.steps.enabled = false;
}

}  // namespace pof::sim
