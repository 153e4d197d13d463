// Scenario TOML: strict loading through pof::TomlSection (common/base/include/pof/base/toml_reader.hpp).
// Every key is checked for type and range, and an unknown key is an error (a typo such as `tua_s`
// must not silently fall back to a default). Messages name the source, the line and the full key
// path.
#include "pof/sim/scenario.hpp"

#include <cmath>
#include <optional>

#include "builtin_scenarios.hpp"
#include "pof/base/errors.hpp"
#include "pof/base/text_file.hpp"
#include "pof/base/toml_reader.hpp"

namespace pof::sim {

int DaqSettings::resolution_bits() const {
  if (bits > 0) return bits;
  if (device == Device::kUsb6008) return terminal == Terminal::kRse ? 11 : 12;
  return terminal == Terminal::kRse ? 13 : 14;
}

double DaqSettings::lsb_v() const { return 2.0 * range_v / std::ldexp(1.0, resolution_bits()); }

std::string_view to_string(Channel c) {
  switch (c) {
    case Channel::kSensor: return "sensor";
    case Channel::kReference: return "reference";
    case Channel::kPot: return "pot";
  }
  return "?";
}

namespace {

using pof::format_number;
using pof::TomlCheck;
using pof::TomlSection;
using pof::toml_check::integer_in;
const TomlCheck<double> positive = pof::toml_check::positive();
const TomlCheck<double> non_negative = pof::toml_check::non_negative();
const TomlCheck<double> non_zero = pof::toml_check::non_zero();
auto angle_range = [](double v) { return v >= -10 && v <= 100 ? std::string{} : std::string("an angle in [-10, 100] deg"); };
auto velocity = [](double v) { return v > 0 && v <= 10 ? std::string{} : std::string("a velocity in (0, 10] rad/s"); };
// Memory hysteresis and lag: ranges that keep the physics meaningful (and exp() finite).
auto amplitude_range = [](double v) { return std::abs(v) <= 1 ? std::string{} : std::string("a voltage in [-1, 1] V"); };
auto rate_sensitivity_range = [](double v) { return std::abs(v) <= 20 ? std::string{} : std::string("a number in [-20, 20] s/rad"); };
auto width_range = [](double v) { return v > 0 && v <= 180 ? std::string{} : std::string("an angle in (0, 180] deg"); };
auto shape_range = [](double v) { return v >= 0.5 && v <= 20 ? std::string{} : std::string("an exponent in [0.5, 20]"); };
auto beta_fraction_range = [](double v) { return v > 0 && v <= 1 ? std::string{} : std::string("a fraction in (0, 1]"); };
auto lag_tau_range = [](double v) { return v > 0 && v <= 600 ? std::string{} : std::string("a time constant in (0, 600] s"); };
// Preisach density (docs/simulator.md).
auto spread_range = [](double v) { return v >= 0 && v <= 90 ? std::string{} : std::string("a spread in [0, 90] deg"); };
auto half_width_range = [](double v) { return v > 0 && v <= 90 ? std::string{} : std::string("a half-width in (0, 90] deg"); };
// Power-law relaxation. max_time_s / min_time_s: at least a decade (a power law over less is not
// one), at most 8 (the bank, 3 terms per decade over the range and a decade either side, stays
// <= 32 terms).
auto exponent_range = [](double v) { return v > 0 && v < 1 ? std::string{} : std::string("an exponent in (0, 1)"); };
auto relaxation_time_range = [](double v) { return v >= 1e-3 && v <= 1e5 ? std::string{} : std::string("a time in [0.001, 100000] s"); };
auto gain_range = [](double v) { return std::abs(v) <= 0.1 ? std::string{} : std::string("a gain in [-0.1, 0.1] V/deg"); };
constexpr double kMinRelaxationRange = 10, kMaxRelaxationRange = 1e8;
// Cyclic softening.
auto depth_range = [](double v) { return v >= 0 && v < 1 ? std::string{} : std::string("a fraction in [0, 1)"); };
auto travel_scale_range = [](double v) { return v > 0 && v <= 1e9 ? std::string{} : std::string("a travel in (0, 1e9] deg"); };
auto probability = [](double v) { return v >= 0 && v <= 1 ? std::string{} : std::string("a probability in [0, 1]"); };

// An optional array of numbers, each satisfying `each`, read into `out` when present.
void numbers(TomlSection& s, std::string_view key, std::vector<double>& out, const TomlCheck<double>& each) {
  if (const std::optional<pof::TomlArray> a = s.find_array(key)) out = a->values<double>(each);
}

void read_direction(TomlSection& s, pof::core::DirectionCoefficients& d) {
  d.c3 = s.get_or("c3", d.c3);
  d.c4 = s.get_or("c4", d.c4, non_zero);
  d.c5 = s.get_or("c5", d.c5);
  d.c6 = s.get_or("c6", d.c6);
  d.c7 = s.get_or("c7", d.c7, non_zero);
  d.c8 = s.get_or("c8", d.c8);
}

Segment read_segment(TomlSection& s) {
  Segment g;
  const std::optional<std::string> kind = s.find<std::string>("kind");
  if (!kind) s.fail("kind", "missing (one of 'quasi_static', 'cycles', 'table1', 'table3', 'subject', 'gait', 'hold', 'random_moves')");
  g.label = *kind;
  if (g.label == "quasi_static") {
    g.kind = SegmentKind::kQuasiStatic;
  } else if (g.label == "cycles") {
    g.kind = SegmentKind::kCycles;
  } else if (g.label == "table1") {
    g.kind = SegmentKind::kCycles;
    g.velocities_rad_s.assign(kTable1Velocities.begin(), kTable1Velocities.end());
  } else if (g.label == "table3") {
    g.kind = SegmentKind::kCycles;
    g.velocities_rad_s.assign(kTable3Velocities.begin(), kTable3Velocities.end());
    g.cycles_per_velocity = 3;
    g.min_deg = 10;
    g.max_deg = 80;
  } else if (g.label == "subject") {
    g.kind = SegmentKind::kSubject;
    g.velocities_rad_s = {0.16};
    g.cycles_per_velocity = 5;
    g.min_deg = 10;
    g.max_deg = 80;
    g.velocity_jitter_rel = 0.08;
    g.amplitude_jitter_deg = 1.5;
  } else if (g.label == "gait") {
    g.kind = SegmentKind::kGait;
    g.min_deg = 5;
    g.max_deg = 60;
  } else if (g.label == "hold") {
    g.kind = SegmentKind::kHold;
  } else if (g.label == "random_moves") {
    g.kind = SegmentKind::kRandomMoves;
    g.min_deg = 10;
    g.max_deg = 80;
  } else {
    s.fail("kind", "expected one of 'quasi_static', 'cycles', 'table1', 'table3', 'subject', 'gait', 'hold', 'random_moves', got '" + pof::excerpt(g.label) + "'");
  }
  g.move_velocity_rad_s = s.get_or("move_velocity_rad_s", g.move_velocity_rad_s, velocity);
  switch (g.kind) {
    case SegmentKind::kQuasiStatic:
      g.from_deg = s.get_or("from_deg", g.from_deg, angle_range);
      g.to_deg = s.get_or("to_deg", g.to_deg, angle_range);
      g.step_deg = s.get_or("step_deg", g.step_deg, positive);
      g.hold_s = s.get_or("hold_s", g.hold_s, non_negative);
      g.descending = s.get_or("descending", g.descending);
      break;
    case SegmentKind::kCycles:
    case SegmentKind::kSubject:
      numbers(s, "velocities_rad_s", g.velocities_rad_s, velocity);
      g.cycles_per_velocity = s.get_or("cycles_per_velocity", g.cycles_per_velocity, integer_in(1, 10000));
      g.min_deg = s.get_or("min_deg", g.min_deg, angle_range);
      g.max_deg = s.get_or("max_deg", g.max_deg, angle_range);
      g.pause_s = s.get_or("pause_s", g.pause_s, non_negative);
      if (g.kind == SegmentKind::kSubject) {
        g.velocity_jitter_rel = s.get_or("velocity_jitter_rel", g.velocity_jitter_rel, [](double v) { return v >= 0 && v < 0.5 ? std::string{} : std::string("a number in [0, 0.5)"); });
        g.amplitude_jitter_deg = s.get_or("amplitude_jitter_deg", g.amplitude_jitter_deg, non_negative);
      }
      if (g.velocities_rad_s.empty()) s.fail("velocities_rad_s", "expected at least one velocity");
      break;
    case SegmentKind::kGait:
      g.cycles = s.get_or("cycles", g.cycles, integer_in(1, 100000));
      g.period_s = s.get_or("period_s", g.period_s, [](double v) { return v >= 0.5 ? std::string{} : std::string("a period >= 0.5 s"); });
      g.min_deg = s.get_or("min_deg", g.min_deg, angle_range);
      g.max_deg = s.get_or("max_deg", g.max_deg, angle_range);
      g.stance_peak_deg = s.get_or("stance_peak_deg", g.stance_peak_deg, non_negative);
      break;
    case SegmentKind::kRandomMoves:
      g.moves = s.get_or("moves", g.moves, integer_in(1, 100000));
      g.min_deg = s.get_or("min_deg", g.min_deg, angle_range);
      g.max_deg = s.get_or("max_deg", g.max_deg, angle_range);
      g.min_velocity_rad_s = s.get_or("min_velocity_rad_s", g.min_velocity_rad_s, velocity);
      g.max_velocity_rad_s = s.get_or("max_velocity_rad_s", g.max_velocity_rad_s, velocity);
      g.min_hold_s = s.get_or("min_hold_s", g.min_hold_s, non_negative);
      g.max_hold_s = s.get_or("max_hold_s", g.max_hold_s, non_negative);
      g.reversal_probability = s.get_or("reversal_probability", g.reversal_probability, probability);
      if (g.max_velocity_rad_s < g.min_velocity_rad_s)
        s.fail("max_velocity_rad_s", "expected max_velocity_rad_s >= min_velocity_rad_s, got " + format_number(g.max_velocity_rad_s) + " < " + format_number(g.min_velocity_rad_s));
      if (g.max_hold_s < g.min_hold_s)
        s.fail("max_hold_s", "expected max_hold_s >= min_hold_s, got " + format_number(g.max_hold_s) + " < " + format_number(g.min_hold_s));
      break;
    case SegmentKind::kHold:
      g.duration_s = s.get_or("duration_s", g.duration_s, non_negative);
      if (const std::optional<double> angle = s.find<double>("angle_deg", angle_range)) {
        g.has_angle = true;
        g.angle_deg = *angle;
      }
      break;
  }
  if ((g.kind == SegmentKind::kCycles || g.kind == SegmentKind::kSubject || g.kind == SegmentKind::kGait ||
       g.kind == SegmentKind::kRandomMoves) && !(g.max_deg > g.min_deg))
    s.fail("max_deg", "expected max_deg > min_deg, got " + format_number(g.max_deg) + " <= " + format_number(g.min_deg));
  if (g.kind == SegmentKind::kQuasiStatic && !(g.to_deg > g.from_deg))
    s.fail("to_deg", "expected to_deg > from_deg");
  return g;
}

const std::initializer_list<std::pair<std::string_view, Channel>> kChannelNames{
    {"sensor", Channel::kSensor}, {"reference", Channel::kReference}, {"pot", Channel::kPot}};

Scenario read_scenario(const toml::table& root, const std::string& source) {
  Scenario sc;
  sc.source = source;
  TomlSection top(root, source);
  sc.schema_version = top.schema_version({1});
  sc.name = top.get_or("name", sc.name);
  sc.description = top.get_or("description", sc.description);
  sc.sensor_id = top.get_or("sensor_id", sc.sensor_id);
  sc.duration_s = top.get_or("duration_s", sc.duration_s, non_negative);
  sc.loop = top.get_or("loop", sc.loop);

  top.with_section("knee", [&](TomlSection& k) {
    KneeSettings& kn = sc.knee;
    kn.start_deg = k.get_or("start_deg", kn.start_deg, angle_range);
    kn.max_velocity_rad_s = k.get_or("max_velocity_rad_s", kn.max_velocity_rad_s, velocity);
    kn.max_acceleration_rad_s2 = k.get_or("max_acceleration_rad_s2", kn.max_acceleration_rad_s2, positive);
    kn.tracking_gain_per_s = k.get_or("tracking_gain_per_s", kn.tracking_gain_per_s, positive);
    k.with_section("backlash", [&](TomlSection& b) {
      kn.backlash.enabled = b.get_or("enabled", kn.backlash.enabled);
      kn.backlash.width_deg = b.get_or("width_deg", kn.backlash.width_deg, non_negative);
    });
    k.with_section("vibration", [&](TomlSection& v) {
      kn.vibration.enabled = v.get_or("enabled", kn.vibration.enabled);
      kn.vibration.amplitude_deg = v.get_or("amplitude_deg", kn.vibration.amplitude_deg, non_negative);
      kn.vibration.frequency_hz = v.get_or("frequency_hz", kn.vibration.frequency_hz, positive);
      kn.vibration.onset_deg = v.get_or("onset_deg", kn.vibration.onset_deg, [](double x) { return x >= 0 && x < 90 ? std::string{} : std::string("an angle in [0, 90) deg"); });
    });
    k.with_section("potentiometer", [&](TomlSection& p) {
      kn.potentiometer.zero_v = p.get_or("zero_v", kn.potentiometer.zero_v);
      kn.potentiometer.deg_per_volt = p.get_or("deg_per_volt", kn.potentiometer.deg_per_volt, non_zero);
      p.with_section("linearity", [&](TomlSection& l) {
        auto& lin = kn.potentiometer.linearity;
        lin.enabled = l.get_or("enabled", lin.enabled);
        lin.error_pct = l.get_or("error_pct", lin.error_pct, [](double x) { return x >= 0 && x <= 20 ? std::string{} : std::string("a percentage in [0, 20]"); });
        lin.span_deg = l.get_or("span_deg", lin.span_deg, positive);
        lin.shape = l.get_enum_or("shape", lin.shape, {{"bow", LinearityShape::kBow}, {"s", LinearityShape::kS}});
      });
    });
  });

  top.with_section("sensor", [&](TomlSection& s) {
    SensorSettings& se = sc.sensor;
    se.hold_threshold_rad_s = s.get_or("hold_threshold_rad_s", se.hold_threshold_rad_s, non_negative);
    s.with_section("model", [&](TomlSection& m) {
      se.model.c1 = m.get_or("c1", se.model.c1);
      se.model.c2 = m.get_or("c2", se.model.c2);
      se.model.c9 = m.get_or("c9", se.model.c9, non_zero);
      se.model.c10 = m.get_or("c10", se.model.c10);
      m.with_section("flexion", [&](TomlSection& d) { read_direction(d, se.model.flexion); });
      m.with_section("extension", [&](TomlSection& d) { read_direction(d, se.model.extension); });
    });
    s.with_section("hysteresis", [&](TomlSection& h) {
      se.hysteresis.enabled = h.get_or("enabled", se.hysteresis.enabled);
      se.hysteresis.scale = h.get_or("scale", se.hysteresis.scale);
    });
    s.with_section("static_nonlinearity", [&](TomlSection& n) {
      se.static_nonlinearity.enabled = n.get_or("enabled", se.static_nonlinearity.enabled);
      se.static_nonlinearity.bow_v = n.get_or("bow_v", se.static_nonlinearity.bow_v);
      se.static_nonlinearity.s_v = n.get_or("s_v", se.static_nonlinearity.s_v);
    });
    s.with_section("rate_dependent_hysteresis", [&](TomlSection& r) {
      se.rate_dependent_hysteresis.enabled = r.get_or("enabled", se.rate_dependent_hysteresis.enabled);
      se.rate_dependent_hysteresis.amplitude_v = r.get_or("amplitude_v", se.rate_dependent_hysteresis.amplitude_v);
      se.rate_dependent_hysteresis.velocity_scale_rad_s = r.get_or("velocity_scale_rad_s", se.rate_dependent_hysteresis.velocity_scale_rad_s, positive);
    });
    s.with_section("creep", [&](TomlSection& c) {
      se.creep.enabled = c.get_or("enabled", se.creep.enabled);
      if (const std::optional<pof::TomlArray> a = c.find_array("terms")) {
        if (a->empty()) a->fail("expected a non-empty array of tables {tau_s, gain_v_per_deg}");
        se.creep.terms.clear();
        for (std::size_t i = 0; i < a->size(); ++i) {
          TomlSection t = a->section(i);
          CreepTerm term;
          term.tau_s = t.get_or("tau_s", term.tau_s, positive);
          term.gain_v_per_deg = t.get_or("gain_v_per_deg", term.gain_v_per_deg);
          t.finish();
          se.creep.terms.push_back(term);
        }
      }
    });
    s.with_section("acceleration_dependence", [&](TomlSection& a) {
      se.acceleration_dependence.enabled = a.get_or("enabled", se.acceleration_dependence.enabled);
      se.acceleration_dependence.gain_v_per_rad_s2 = a.get_or("gain_v_per_rad_s2", se.acceleration_dependence.gain_v_per_rad_s2);
    });
    s.with_section("drift", [&](TomlSection& d) {
      se.drift.enabled = d.get_or("enabled", se.drift.enabled);
      se.drift.rate_v_per_hour = d.get_or("rate_v_per_hour", se.drift.rate_v_per_hour);
      se.drift.random_walk_v_per_sqrt_hour = d.get_or("random_walk_v_per_sqrt_hour", se.drift.random_walk_v_per_sqrt_hour, non_negative);
      se.drift.wave_v = d.get_or("wave_v", se.drift.wave_v, non_negative);
      se.drift.wave_period_s = d.get_or("wave_period_s", se.drift.wave_period_s, positive);
    });
    s.with_section("memory_hysteresis", [&](TomlSection& h) {
      auto& mh = se.memory_hysteresis;
      mh.enabled = h.get_or("enabled", mh.enabled);
      mh.family = h.get_enum_or("family", mh.family, {{"bouc_wen", MemoryHysteresisFamily::kBoucWen}, {"maxwell_slip", MemoryHysteresisFamily::kMaxwellSlip},
                                                       {"preisach", MemoryHysteresisFamily::kPreisach}});
      mh.amplitude_v = h.get_or("amplitude_v", mh.amplitude_v, amplitude_range);
      mh.rate_sensitivity_s_per_rad = h.get_or("rate_sensitivity_s_per_rad", mh.rate_sensitivity_s_per_rad, rate_sensitivity_range);
      mh.rate_filter_s = h.get_or("rate_filter_s", mh.rate_filter_s, non_negative);
      mh.width_deg = h.get_or("width_deg", mh.width_deg, width_range);
      mh.shape = h.get_or("shape", mh.shape, shape_range);
      mh.beta_fraction = h.get_or("beta_fraction", mh.beta_fraction, beta_fraction_range);
      const bool has_thresholds = h.has("thresholds_deg"), has_weights = h.has("weights");
      numbers(h, "thresholds_deg", mh.thresholds_deg, width_range);
      numbers(h, "weights", mh.weights, non_negative);
      if (has_thresholds && mh.thresholds_deg.empty()) h.fail("thresholds_deg", "expected at least one threshold");
      if (has_thresholds && !has_weights) mh.weights.assign(mh.thresholds_deg.size(), 1.0);  // equal weights
      if (mh.weights.size() != mh.thresholds_deg.size())
        h.fail("weights", "expected as many entries as thresholds_deg (" + std::to_string(mh.thresholds_deg.size()) + "), got " + std::to_string(mh.weights.size()));
      double wsum = 0;
      for (double w : mh.weights) wsum += w;
      if (!(wsum > 0)) h.fail("weights", "expected at least one weight > 0");
      mh.centre_deg = h.get_or("centre_deg", mh.centre_deg, angle_range);
      mh.centre_spread_deg = h.get_or("centre_spread_deg", mh.centre_spread_deg, spread_range);
      mh.half_width_deg = h.get_or("half_width_deg", mh.half_width_deg, half_width_range);
      mh.half_width_spread_deg = h.get_or("half_width_spread_deg", mh.half_width_spread_deg, spread_range);
    });
    s.with_section("viscoelastic_lag", [&](TomlSection& l) {
      se.viscoelastic_lag.enabled = l.get_or("enabled", se.viscoelastic_lag.enabled);
      se.viscoelastic_lag.tau_s = l.get_or("tau_s", se.viscoelastic_lag.tau_s, lag_tau_range);
    });
    s.with_section("power_law_relaxation", [&](TomlSection& p) {
      auto& pl = se.power_law_relaxation;
      pl.enabled = p.get_or("enabled", pl.enabled);
      pl.gain_v_per_deg = p.get_or("gain_v_per_deg", pl.gain_v_per_deg, gain_range);
      pl.exponent = p.get_or("exponent", pl.exponent, exponent_range);
      pl.min_time_s = p.get_or("min_time_s", pl.min_time_s, relaxation_time_range);
      pl.max_time_s = p.get_or("max_time_s", pl.max_time_s, relaxation_time_range);
      const double ratio = pl.max_time_s / pl.min_time_s;
      if (!(ratio >= kMinRelaxationRange && ratio <= kMaxRelaxationRange))
        p.fail("max_time_s", "expected max_time_s / min_time_s in [10, 1e8] (a power law over 1 to 8 decades), got " + format_number(pl.max_time_s) +
                                 " / " + format_number(pl.min_time_s));
    });
    s.with_section("cyclic_softening", [&](TomlSection& c) {
      auto& cs = se.cyclic_softening;
      cs.enabled = c.get_or("enabled", cs.enabled);
      cs.depth = c.get_or("depth", cs.depth, depth_range);
      cs.loop_depth = c.get_or("loop_depth", cs.loop_depth, depth_range);
      cs.travel_scale_deg = c.get_or("travel_scale_deg", cs.travel_scale_deg, travel_scale_range);
    });
  });

  top.with_section("light", [&](TomlSection& l) {
    LightSettings& li = sc.light;
    li.reference_level_v = l.get_or("reference_level_v", li.reference_level_v, positive);
    l.with_section("wander", [&](TomlSection& w) {
      li.wander.enabled = w.get_or("enabled", li.wander.enabled);
      li.wander.sigma_rel = w.get_or("sigma_rel", li.wander.sigma_rel, [](double x) { return x >= 0 && x < 0.3 ? std::string{} : std::string("a number in [0, 0.3)"); });
      li.wander.tau_s = w.get_or("tau_s", li.wander.tau_s, positive);
    });
    l.with_section("steps", [&](TomlSection& st) {
      li.steps.enabled = st.get_or("enabled", li.steps.enabled);
      std::vector<double> at, rel;
      numbers(st, "at_s", at, non_negative);
      numbers(st, "relative_change", rel, [](double x) { return x > -0.9 && x < 10 ? std::string{} : std::string("a number in (-0.9, 10)"); });
      if (at.size() != rel.size())
        st.fail("relative_change", "expected as many entries as at_s (" + std::to_string(at.size()) + "), got " + std::to_string(rel.size()));
      li.steps.steps.clear();
      for (std::size_t i = 0; i < at.size(); ++i) {
        if (i > 0 && at[i] < at[i - 1]) st.fail("at_s", "expected increasing times");
        li.steps.steps.push_back({at[i], rel[i]});
      }
    });
    l.with_section("source_power_coupling", [&](TomlSection& c) {
      li.source_power_coupling.enabled = c.get_or("enabled", li.source_power_coupling.enabled);
      li.source_power_coupling.sensor_exponent = c.get_or("sensor_exponent", li.source_power_coupling.sensor_exponent, [](double x) { return x > 0 && x < 5 ? std::string{} : std::string("a number in (0, 5)"); });
      li.source_power_coupling.reference_offset_v = c.get_or("reference_offset_v", li.source_power_coupling.reference_offset_v);
    });
  });

  top.with_section("daq", [&](TomlSection& d) {
    DaqSettings& q = sc.daq;
    q.device = d.get_enum_or("device", q.device, {{"usb6008", Device::kUsb6008}, {"usb6009", Device::kUsb6009}});
    q.terminal = d.get_enum_or("terminal", q.terminal, {{"rse", Terminal::kRse}, {"differential", Terminal::kDifferential}});
    q.range_v = d.get_or("range_v", q.range_v, positive);
    q.bits = d.get_or("bits", q.bits, integer_in(0, 24));
    q.scan_rate_hz = d.get_or("scan_rate_hz", q.scan_rate_hz, [](double x) { return x > 0 && x <= 48000 ? std::string{} : std::string("a rate in (0, 48000] Hz"); });
    q.convert_interval_s = d.get_or("convert_interval_s", q.convert_interval_s, non_negative);
    q.multiplexed = d.get_or("multiplexed", q.multiplexed);
    if (const std::optional<pof::TomlArray> a = d.find_array("order")) {
      if (a->size() != kChannels)
        a->fail("expected an array of the 3 channel names, e.g. [\"sensor\", \"reference\", \"pot\"]");
      std::array<bool, kChannels> seen{};
      for (std::size_t i = 0; i < kChannels; ++i) {
        const std::string name = a->get<std::string>(i);
        bool ok = false;
        for (const auto& [cn, cv] : kChannelNames) {
          if (name == cn && !seen[static_cast<std::size_t>(cv)]) {
            q.order[i] = cv;
            seen[static_cast<std::size_t>(cv)] = true;
            ok = true;
          }
        }
        if (!ok) a->fail(i, "expected 'sensor', 'reference' or 'pot', each once, got '" + pof::excerpt(name) + "'");
      }
    }
    d.with_section("noise", [&](TomlSection& n) {
      q.noise.enabled = n.get_or("enabled", q.noise.enabled);
      q.noise.sensor_v = n.get_or("sensor_v", q.noise.sensor_v, non_negative);
      q.noise.reference_v = n.get_or("reference_v", q.noise.reference_v, non_negative);
      q.noise.pot_v = n.get_or("pot_v", q.noise.pot_v, non_negative);
    });
    d.with_section("periodic_interference", [&](TomlSection& m) {
      q.periodic_interference.enabled = m.get_or("enabled", q.periodic_interference.enabled);
      q.periodic_interference.frequency_hz = m.get_or("frequency_hz", q.periodic_interference.frequency_hz, positive);
      q.periodic_interference.amplitude_v = m.get_or("amplitude_v", q.periodic_interference.amplitude_v, non_negative);
      q.periodic_interference.phase_deg = m.get_or("phase_deg", q.periodic_interference.phase_deg);
      q.periodic_interference.third_harmonic_rel = m.get_or("third_harmonic_rel", q.periodic_interference.third_harmonic_rel, non_negative);
    });
    d.with_section("time_delay", [&](TomlSection& t) {
      q.time_delay.enabled = t.get_or("enabled", q.time_delay.enabled);
      q.time_delay.channel = t.get_enum_or("channel", q.time_delay.channel, kChannelNames);
      q.time_delay.delay_s = t.get_or("delay_s", q.time_delay.delay_s, [](double x) { return x >= 0 && x <= 10 ? std::string{} : std::string("a delay in [0, 10] s"); });
    });
    if (q.terminal == Terminal::kRse && q.range_v != 10)
      d.fail("range_v", "expected 10 (RSE inputs of the USB-6008/6009 are +-10 V only), got " + format_number(q.range_v));
    if (q.terminal == Terminal::kDifferential) {
      static constexpr std::array<double, 8> kRanges{20, 10, 5, 4, 2.5, 2, 1.25, 1};
      bool ok = false;
      for (double r : kRanges) ok = ok || r == q.range_v;
      if (!ok) d.fail("range_v", "expected a differential range of the USB-6008/6009 (20, 10, 5, 4, 2.5, 2, 1.25 or 1 V), got " + format_number(q.range_v));
    }
  });

  const std::optional<pof::TomlArray> segs = top.find_array("trajectory");
  if (!segs) top.fail("trajectory", "missing: add at least one [[trajectory]] segment");
  if (segs->empty()) segs->fail("expected a non-empty array of [[trajectory]] tables");
  for (std::size_t i = 0; i < segs->size(); ++i) {
    TomlSection s = segs->section(i);
    sc.trajectory.push_back(read_segment(s));
    s.finish();
  }
  top.finish();
  return sc;
}

}  // namespace

void validate(const Scenario& s) {
  const std::string src = s.source.empty() ? std::string("scenario") : s.source;
  auto bad = [&](const std::string& key, const std::string& what) {
    throw pof::ConfigError(src + ": key '" + key + "': " + what);
  };
  if (s.schema_version != 1) bad("schema_version", "expected 1, got " + std::to_string(s.schema_version));
  if (s.trajectory.empty()) bad("trajectory", "expected at least one segment");
  if (!(s.daq.scan_rate_hz > 0)) bad("daq.scan_rate_hz", "expected a rate > 0");
  if (!(s.daq.range_v > 0)) bad("daq.range_v", "expected a range > 0");
  const int bits = s.daq.resolution_bits();
  if (bits < 1 || bits > 24) bad("daq.bits", "expected 1..24 bits");
  if (!(s.knee.max_velocity_rad_s > 0)) bad("knee.max_velocity_rad_s", "expected a number > 0");
  if (!(s.knee.max_acceleration_rad_s2 > 0)) bad("knee.max_acceleration_rad_s2", "expected a number > 0");
  if (s.knee.potentiometer.deg_per_volt == 0) bad("knee.potentiometer.deg_per_volt", "expected a non-zero number");
  if (!(s.light.reference_level_v > 0)) bad("light.reference_level_v", "expected a number > 0");
  if (s.sensor.creep.enabled && s.sensor.creep.terms.empty()) bad("sensor.creep.terms", "expected at least one term");
  for (std::size_t i = 0; i < s.sensor.creep.terms.size(); ++i)
    if (!(s.sensor.creep.terms[i].tau_s > 0)) bad("sensor.creep.terms[" + std::to_string(i) + "].tau_s", "expected a number > 0");
  {
    const auto& mh = s.sensor.memory_hysteresis;
    const std::string k = "sensor.memory_hysteresis.";
    auto check = [&](const std::string& key, double v, const TomlCheck<double>& rule) {
      const std::string want = std::isfinite(v) ? rule.want(v) : std::string("a finite number");
      if (!want.empty()) bad(k + key, "expected " + want + ", got " + format_number(v));
    };
    if (mh.family != MemoryHysteresisFamily::kBoucWen && mh.family != MemoryHysteresisFamily::kMaxwellSlip &&
        mh.family != MemoryHysteresisFamily::kPreisach)
      bad(k + "family", "expected 'bouc_wen', 'maxwell_slip' or 'preisach'");
    check("amplitude_v", mh.amplitude_v, amplitude_range);
    check("rate_sensitivity_s_per_rad", mh.rate_sensitivity_s_per_rad, rate_sensitivity_range);
    check("rate_filter_s", mh.rate_filter_s, non_negative);
    check("width_deg", mh.width_deg, width_range);
    check("shape", mh.shape, shape_range);
    check("beta_fraction", mh.beta_fraction, beta_fraction_range);
    if (mh.family == MemoryHysteresisFamily::kMaxwellSlip || !mh.thresholds_deg.empty()) {
      if (mh.thresholds_deg.empty()) bad(k + "thresholds_deg", "expected at least one threshold");
      if (mh.weights.size() != mh.thresholds_deg.size())
        bad(k + "weights", "expected as many entries as thresholds_deg (" + std::to_string(mh.thresholds_deg.size()) + "), got " + std::to_string(mh.weights.size()));
      double wsum = 0;
      for (std::size_t i = 0; i < mh.thresholds_deg.size(); ++i) {
        check("thresholds_deg[" + std::to_string(i) + "]", mh.thresholds_deg[i], width_range);
        check("weights[" + std::to_string(i) + "]", mh.weights[i], non_negative);
        wsum += mh.weights[i];
      }
      if (!(wsum > 0)) bad(k + "weights", "expected at least one weight > 0");
    }
    check("centre_deg", mh.centre_deg, angle_range);
    check("centre_spread_deg", mh.centre_spread_deg, spread_range);
    check("half_width_deg", mh.half_width_deg, half_width_range);
    check("half_width_spread_deg", mh.half_width_spread_deg, spread_range);
    check("viscoelastic_lag.tau_s", s.sensor.viscoelastic_lag.tau_s, lag_tau_range);
  }
  {
    auto check = [&](const std::string& key, double v, const TomlCheck<double>& rule) {
      const std::string want = std::isfinite(v) ? rule.want(v) : std::string("a finite number");
      if (!want.empty()) bad("sensor." + key, "expected " + want + ", got " + format_number(v));
    };
    const auto& pl = s.sensor.power_law_relaxation;
    check("power_law_relaxation.gain_v_per_deg", pl.gain_v_per_deg, gain_range);
    check("power_law_relaxation.exponent", pl.exponent, exponent_range);
    check("power_law_relaxation.min_time_s", pl.min_time_s, relaxation_time_range);
    check("power_law_relaxation.max_time_s", pl.max_time_s, relaxation_time_range);
    const double ratio = pl.max_time_s / pl.min_time_s;
    if (!(ratio >= kMinRelaxationRange && ratio <= kMaxRelaxationRange))
      bad("sensor.power_law_relaxation.max_time_s", "expected max_time_s / min_time_s in [10, 1e8]");
    const auto& cs = s.sensor.cyclic_softening;
    check("cyclic_softening.depth", cs.depth, depth_range);
    check("cyclic_softening.loop_depth", cs.loop_depth, depth_range);
    check("cyclic_softening.travel_scale_deg", cs.travel_scale_deg, travel_scale_range);
  }
  if (s.light.wander.enabled && !(s.light.wander.tau_s > 0)) bad("light.wander.tau_s", "expected a number > 0");
  if (s.daq.time_delay.enabled && !(s.daq.time_delay.delay_s >= 0)) bad("daq.time_delay.delay_s", "expected a number >= 0");
  for (std::size_t i = 0; i < s.trajectory.size(); ++i) {
    const Segment& g = s.trajectory[i];
    const std::string k = "trajectory[" + std::to_string(i) + "]";
    if ((g.kind == SegmentKind::kCycles || g.kind == SegmentKind::kSubject) && g.velocities_rad_s.empty())
      bad(k + ".velocities_rad_s", "expected at least one velocity");
    for (double v : g.velocities_rad_s)
      if (!(v > 0)) bad(k + ".velocities_rad_s", "expected velocities > 0");
    if (g.kind == SegmentKind::kQuasiStatic && !(g.step_deg > 0)) bad(k + ".step_deg", "expected a number > 0");
    if (g.kind == SegmentKind::kGait && !(g.period_s > 0)) bad(k + ".period_s", "expected a number > 0");
    if (!(g.move_velocity_rad_s > 0)) bad(k + ".move_velocity_rad_s", "expected a number > 0");
    if (g.kind == SegmentKind::kRandomMoves) {
      if (g.moves < 1) bad(k + ".moves", "expected at least 1 move");
      if (!(g.max_deg > g.min_deg)) bad(k + ".max_deg", "expected max_deg > min_deg");
      if (!(g.min_velocity_rad_s > 0) || !(g.max_velocity_rad_s >= g.min_velocity_rad_s))
        bad(k + ".max_velocity_rad_s", "expected 0 < min_velocity_rad_s <= max_velocity_rad_s");
      if (!(g.min_hold_s >= 0) || !(g.max_hold_s >= g.min_hold_s)) bad(k + ".max_hold_s", "expected 0 <= min_hold_s <= max_hold_s");
      if (!(g.reversal_probability >= 0 && g.reversal_probability <= 1)) bad(k + ".reversal_probability", "expected a probability in [0, 1]");
    }
  }
}

Scenario parse_scenario(std::string_view toml_text, const std::string& source) {
  Scenario sc = read_scenario(pof::parse_toml(toml_text, source), source);
  if (sc.name.empty()) sc.name = std::filesystem::path(source).stem().string();
  validate(sc);
  return sc;
}

Scenario load_scenario(const std::filesystem::path& path) {
  return parse_scenario(pof::read_text_file(path.string(), "scenario file"), path.string());
}

Scenario builtin_scenario(std::string_view name) {
  for (const auto& b : detail::kBuiltinScenarios) {
    if (b.name == name) {
      Scenario sc = parse_scenario(b.toml, "builtin:" + std::string(name));
      sc.name = std::string(name);
      return sc;
    }
  }
  std::string list;
  for (const auto& b : detail::kBuiltinScenarios) list += (list.empty() ? "" : ", ") + std::string(b.name);
  throw pof::NoInputError("no builtin scenario '" + std::string(name) + "' (builtin: " + list + ")");
}

Scenario scenario_by_name_or_path(const std::string& name_or_path) {
  const bool is_path = name_or_path.find('/') != std::string::npos ||
                       (name_or_path.size() > 5 && name_or_path.ends_with(".toml"));
  return is_path ? load_scenario(name_or_path) : builtin_scenario(name_or_path);
}

std::vector<std::string> builtin_scenario_names() {
  std::vector<std::string> v;
  for (const auto& b : detail::kBuiltinScenarios) v.emplace_back(b.name);
  return v;
}

}  // namespace pof::sim
