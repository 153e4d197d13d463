// Scenario TOML: strict loading. Every key is checked for type and range, and an unknown key is an
// error (a typo such as `tua_s` must not silently fall back to a default). Messages name the
// source, the line and the full key path, as the house rules ask (brief: "Bad input").
#include "pof/sim/scenario.hpp"

#include <cmath>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "builtin_scenarios.hpp"
#include "pof/base/errors.hpp"
#include "pof/base/text_file.hpp"

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

std::string fmt_num(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

std::string describe(const toml::node& n) {
  std::ostringstream o;
  if (n.is_string()) {
    o << '\'' << pof::excerpt(*n.value<std::string>()) << '\'';
  } else if (n.is_table()) {
    o << "a table";
  } else if (n.is_array()) {
    o << "an array";
  } else {
    n.visit([&o](const auto& x) {
      if constexpr (toml::is_value<decltype(x)>) o << x;
    });
  }
  return o.str();
}

// A view of one TOML table that remembers which keys were read, so the unknown ones can be named.
class Section {
 public:
  Section(const toml::table& t, std::string path, const std::string& source)
      : t_(t), path_(std::move(path)), source_(source) {}

  [[nodiscard]] std::string key_path(std::string_view key) const {
    return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
  }

  [[noreturn]] void fail_at(const toml::node* n, std::string_view key, const std::string& what) const {
    std::string where = source_;
    if (n != nullptr && n->source().begin.line > 0) where += ":" + std::to_string(n->source().begin.line);
    else if (t_.source().begin.line > 0) where += ":" + std::to_string(t_.source().begin.line);
    throw pof::ConfigError(where + ": key '" + key_path(key) + "': " + what);
  }

  const toml::node* get(std::string_view key) {
    used_.insert(std::string(key));
    return t_.get(key);
  }

  // A number (integer or float); `check` returns an empty string when the value is acceptable,
  // else what was expected.
  void number(std::string_view key, double& out, const std::function<std::string(double)>& check = {}) {
    const toml::node* n = get(key);
    if (n == nullptr) return;
    if (!n->is_number()) fail_at(n, key, "expected a number, got " + describe(*n));
    const double v = *n->value<double>();
    if (!std::isfinite(v)) fail_at(n, key, "expected a finite number, got " + describe(*n));
    if (check) {
      const std::string want = check(v);
      if (!want.empty()) fail_at(n, key, "expected " + want + ", got " + fmt_num(v));
    }
    out = v;
  }
  void integer(std::string_view key, int& out, int lo, int hi) {
    const toml::node* n = get(key);
    if (n == nullptr) return;
    if (!n->is_integer()) fail_at(n, key, "expected an integer, got " + describe(*n));
    const auto v = *n->value<std::int64_t>();
    if (v < lo || v > hi)
      fail_at(n, key, "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + std::to_string(v));
    out = static_cast<int>(v);
  }
  void boolean(std::string_view key, bool& out) {
    const toml::node* n = get(key);
    if (n == nullptr) return;
    if (!n->is_boolean()) fail_at(n, key, "expected true or false, got " + describe(*n));
    out = *n->value<bool>();
  }
  void string(std::string_view key, std::string& out) {
    const toml::node* n = get(key);
    if (n == nullptr) return;
    if (!n->is_string()) fail_at(n, key, "expected a string, got " + describe(*n));
    out = *n->value<std::string>();
  }
  template <class E>
  void choice(std::string_view key, E& out, std::initializer_list<std::pair<std::string_view, E>> options) {
    const toml::node* n = get(key);
    if (n == nullptr) return;
    std::string list;
    for (const auto& [name, val] : options) list += (list.empty() ? "" : ", ") + ("'" + std::string(name) + "'");
    if (!n->is_string()) fail_at(n, key, "expected one of " + list + ", got " + describe(*n));
    const std::string s = *n->value<std::string>();
    for (const auto& [name, val] : options) {
      if (s == name) {
        out = val;
        return;
      }
    }
    fail_at(n, key, "expected one of " + list + ", got '" + pof::excerpt(s) + "'");
  }
  void numbers(std::string_view key, std::vector<double>& out, const std::function<std::string(double)>& check = {}) {
    const toml::node* n = get(key);
    if (n == nullptr) return;
    const toml::array* a = n->as_array();
    if (a == nullptr) fail_at(n, key, "expected an array of numbers, got " + describe(*n));
    std::vector<double> v;
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = *a->get(i);
      const std::string k = std::string(key) + "[" + std::to_string(i) + "]";
      if (!e.is_number()) fail_at(&e, k, "expected a number, got " + describe(e));
      const double x = *e.value<double>();
      if (!std::isfinite(x)) fail_at(&e, k, "expected a finite number");
      if (check) {
        const std::string want = check(x);
        if (!want.empty()) fail_at(&e, k, "expected " + want + ", got " + fmt_num(x));
      }
      v.push_back(x);
    }
    out = std::move(v);
  }
  // A sub-table (absent: nullopt-like nullptr). Anything other than a table is an error.
  const toml::table* table(std::string_view key) {
    const toml::node* n = get(key);
    if (n == nullptr) return nullptr;
    if (!n->is_table()) fail_at(n, key, "expected a table, got " + describe(*n));
    return n->as_table();
  }
  Section sub(const toml::table& t, std::string_view key) const { return Section(t, key_path(key), source_); }

  // Every key of the table must have been read.
  void finish() const {
    for (const auto& [k, v] : t_) {
      if (!used_.contains(std::string(k.str())))
        fail_at(&v, pof::excerpt(k.str()), "unknown key (misspelt? see docs/simulator.md for the schema)");
    }
  }

 private:
  const toml::table& t_;
  std::string path_;
  const std::string& source_;
  std::set<std::string> used_;
};

auto positive = [](double v) { return v > 0 ? std::string{} : std::string("a number > 0"); };
auto non_negative = [](double v) { return v >= 0 ? std::string{} : std::string("a number >= 0"); };
auto angle_range = [](double v) { return v >= -10 && v <= 100 ? std::string{} : std::string("an angle in [-10, 100] deg"); };
auto velocity = [](double v) { return v > 0 && v <= 10 ? std::string{} : std::string("a velocity in (0, 10] rad/s"); };
// Memory hysteresis and lag: ranges that keep the physics meaningful (and exp() finite).
auto amplitude_range = [](double v) { return std::abs(v) <= 1 ? std::string{} : std::string("a voltage in [-1, 1] V"); };
auto rate_sensitivity_range = [](double v) { return std::abs(v) <= 20 ? std::string{} : std::string("a number in [-20, 20] s/rad"); };
auto width_range = [](double v) { return v > 0 && v <= 180 ? std::string{} : std::string("an angle in (0, 180] deg"); };
auto shape_range = [](double v) { return v >= 0.5 && v <= 20 ? std::string{} : std::string("an exponent in [0.5, 20]"); };
auto beta_fraction_range = [](double v) { return v > 0 && v <= 1 ? std::string{} : std::string("a fraction in (0, 1]"); };
auto lag_tau_range = [](double v) { return v > 0 && v <= 600 ? std::string{} : std::string("a time constant in (0, 600] s"); };
auto probability = [](double v) { return v >= 0 && v <= 1 ? std::string{} : std::string("a probability in [0, 1]"); };

// Runs `fn` on sub-table `key` when present and then checks its keys.
template <class F>
void with_table(Section& parent, std::string_view key, F&& fn) {
  if (const toml::table* t = parent.table(key)) {
    Section s = parent.sub(*t, key);
    fn(s);
    s.finish();
  }
}

void read_direction(Section& s, pof::core::DirectionCoefficients& d) {
  s.number("c3", d.c3);
  s.number("c4", d.c4, [](double v) { return v != 0 ? std::string{} : std::string("a non-zero number"); });
  s.number("c5", d.c5);
  s.number("c6", d.c6);
  s.number("c7", d.c7, [](double v) { return v != 0 ? std::string{} : std::string("a non-zero number"); });
  s.number("c8", d.c8);
}

Segment read_segment(Section& s) {
  Segment g;
  const toml::node* kind_node = s.get("kind");
  if (kind_node == nullptr) s.fail_at(nullptr, "kind", "missing (one of 'quasi_static', 'cycles', 'table1', 'table3', 'subject', 'gait', 'hold', 'random_moves')");
  if (!kind_node->is_string()) s.fail_at(kind_node, "kind", "expected a string, got " + describe(*kind_node));
  g.label = *kind_node->value<std::string>();
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
    s.fail_at(kind_node, "kind", "expected one of 'quasi_static', 'cycles', 'table1', 'table3', 'subject', 'gait', 'hold', 'random_moves', got '" + pof::excerpt(g.label) + "'");
  }
  s.number("move_velocity_rad_s", g.move_velocity_rad_s, velocity);
  switch (g.kind) {
    case SegmentKind::kQuasiStatic:
      s.number("from_deg", g.from_deg, angle_range);
      s.number("to_deg", g.to_deg, angle_range);
      s.number("step_deg", g.step_deg, positive);
      s.number("hold_s", g.hold_s, non_negative);
      s.boolean("descending", g.descending);
      break;
    case SegmentKind::kCycles:
    case SegmentKind::kSubject:
      s.numbers("velocities_rad_s", g.velocities_rad_s, velocity);
      s.integer("cycles_per_velocity", g.cycles_per_velocity, 1, 10000);
      s.number("min_deg", g.min_deg, angle_range);
      s.number("max_deg", g.max_deg, angle_range);
      s.number("pause_s", g.pause_s, non_negative);
      if (g.kind == SegmentKind::kSubject) {
        s.number("velocity_jitter_rel", g.velocity_jitter_rel, [](double v) { return v >= 0 && v < 0.5 ? std::string{} : std::string("a number in [0, 0.5)"); });
        s.number("amplitude_jitter_deg", g.amplitude_jitter_deg, non_negative);
      }
      if (g.velocities_rad_s.empty()) s.fail_at(nullptr, "velocities_rad_s", "expected at least one velocity");
      break;
    case SegmentKind::kGait:
      s.integer("cycles", g.cycles, 1, 100000);
      s.number("period_s", g.period_s, [](double v) { return v >= 0.5 ? std::string{} : std::string("a period >= 0.5 s"); });
      s.number("min_deg", g.min_deg, angle_range);
      s.number("max_deg", g.max_deg, angle_range);
      s.number("stance_peak_deg", g.stance_peak_deg, non_negative);
      break;
    case SegmentKind::kRandomMoves:
      s.integer("moves", g.moves, 1, 100000);
      s.number("min_deg", g.min_deg, angle_range);
      s.number("max_deg", g.max_deg, angle_range);
      s.number("min_velocity_rad_s", g.min_velocity_rad_s, velocity);
      s.number("max_velocity_rad_s", g.max_velocity_rad_s, velocity);
      s.number("min_hold_s", g.min_hold_s, non_negative);
      s.number("max_hold_s", g.max_hold_s, non_negative);
      s.number("reversal_probability", g.reversal_probability, probability);
      if (g.max_velocity_rad_s < g.min_velocity_rad_s)
        s.fail_at(s.get("max_velocity_rad_s"), "max_velocity_rad_s", "expected max_velocity_rad_s >= min_velocity_rad_s, got " + fmt_num(g.max_velocity_rad_s) + " < " + fmt_num(g.min_velocity_rad_s));
      if (g.max_hold_s < g.min_hold_s)
        s.fail_at(s.get("max_hold_s"), "max_hold_s", "expected max_hold_s >= min_hold_s, got " + fmt_num(g.max_hold_s) + " < " + fmt_num(g.min_hold_s));
      break;
    case SegmentKind::kHold:
      s.number("duration_s", g.duration_s, non_negative);
      if (s.get("angle_deg") != nullptr) {
        g.has_angle = true;
        s.number("angle_deg", g.angle_deg, angle_range);
      }
      break;
  }
  if ((g.kind == SegmentKind::kCycles || g.kind == SegmentKind::kSubject || g.kind == SegmentKind::kGait ||
       g.kind == SegmentKind::kRandomMoves) && !(g.max_deg > g.min_deg))
    s.fail_at(s.get("max_deg"), "max_deg", "expected max_deg > min_deg, got " + fmt_num(g.max_deg) + " <= " + fmt_num(g.min_deg));
  if (g.kind == SegmentKind::kQuasiStatic && !(g.to_deg > g.from_deg))
    s.fail_at(s.get("to_deg"), "to_deg", "expected to_deg > from_deg");
  return g;
}

const std::initializer_list<std::pair<std::string_view, Channel>> kChannelNames{
    {"sensor", Channel::kSensor}, {"reference", Channel::kReference}, {"pot", Channel::kPot}};

Scenario read_scenario(const toml::table& root, const std::string& source) {
  Scenario sc;
  sc.source = source;
  Section top(root, "", source);

  const toml::node* ver = top.get("schema_version");
  if (ver == nullptr) top.fail_at(nullptr, "schema_version", "missing (this program reads schema_version = 1)");
  top.integer("schema_version", sc.schema_version, 1, 1);
  top.string("name", sc.name);
  top.string("description", sc.description);
  top.string("sensor_id", sc.sensor_id);
  top.number("duration_s", sc.duration_s, non_negative);
  top.boolean("loop", sc.loop);

  with_table(top, "knee", [&](Section& k) {
    KneeSettings& kn = sc.knee;
    k.number("start_deg", kn.start_deg, angle_range);
    k.number("max_velocity_rad_s", kn.max_velocity_rad_s, velocity);
    k.number("max_acceleration_rad_s2", kn.max_acceleration_rad_s2, positive);
    k.number("tracking_gain_per_s", kn.tracking_gain_per_s, positive);
    with_table(k, "backlash", [&](Section& b) {
      b.boolean("enabled", kn.backlash.enabled);
      b.number("width_deg", kn.backlash.width_deg, non_negative);
    });
    with_table(k, "vibration", [&](Section& v) {
      v.boolean("enabled", kn.vibration.enabled);
      v.number("amplitude_deg", kn.vibration.amplitude_deg, non_negative);
      v.number("frequency_hz", kn.vibration.frequency_hz, positive);
      v.number("onset_deg", kn.vibration.onset_deg, [](double x) { return x >= 0 && x < 90 ? std::string{} : std::string("an angle in [0, 90) deg"); });
    });
    with_table(k, "potentiometer", [&](Section& p) {
      p.number("zero_v", kn.potentiometer.zero_v);
      p.number("deg_per_volt", kn.potentiometer.deg_per_volt, [](double x) { return x != 0 ? std::string{} : std::string("a non-zero number"); });
      with_table(p, "linearity", [&](Section& l) {
        auto& lin = kn.potentiometer.linearity;
        l.boolean("enabled", lin.enabled);
        l.number("error_pct", lin.error_pct, [](double x) { return x >= 0 && x <= 20 ? std::string{} : std::string("a percentage in [0, 20]"); });
        l.number("span_deg", lin.span_deg, positive);
        l.choice("shape", lin.shape, {{"bow", LinearityShape::kBow}, {"s", LinearityShape::kS}});
      });
    });
  });

  with_table(top, "sensor", [&](Section& s) {
    SensorSettings& se = sc.sensor;
    s.number("hold_threshold_rad_s", se.hold_threshold_rad_s, non_negative);
    with_table(s, "model", [&](Section& m) {
      m.number("c1", se.model.c1);
      m.number("c2", se.model.c2);
      m.number("c9", se.model.c9, [](double x) { return x != 0 ? std::string{} : std::string("a non-zero number"); });
      m.number("c10", se.model.c10);
      with_table(m, "flexion", [&](Section& d) { read_direction(d, se.model.flexion); });
      with_table(m, "extension", [&](Section& d) { read_direction(d, se.model.extension); });
    });
    with_table(s, "hysteresis", [&](Section& h) {
      h.boolean("enabled", se.hysteresis.enabled);
      h.number("scale", se.hysteresis.scale);
    });
    with_table(s, "static_nonlinearity", [&](Section& n) {
      n.boolean("enabled", se.static_nonlinearity.enabled);
      n.number("bow_v", se.static_nonlinearity.bow_v);
      n.number("s_v", se.static_nonlinearity.s_v);
    });
    with_table(s, "rate_dependent_hysteresis", [&](Section& r) {
      r.boolean("enabled", se.rate_dependent_hysteresis.enabled);
      r.number("amplitude_v", se.rate_dependent_hysteresis.amplitude_v);
      r.number("velocity_scale_rad_s", se.rate_dependent_hysteresis.velocity_scale_rad_s, positive);
    });
    with_table(s, "creep", [&](Section& c) {
      c.boolean("enabled", se.creep.enabled);
      const toml::node* terms = c.get("terms");
      if (terms != nullptr) {
        const toml::array* a = terms->as_array();
        if (a == nullptr || a->empty())
          c.fail_at(terms, "terms", "expected a non-empty array of tables {tau_s, gain_v_per_deg}");
        se.creep.terms.clear();
        for (std::size_t i = 0; i < a->size(); ++i) {
          const toml::node& e = *a->get(i);
          const std::string k = "terms[" + std::to_string(i) + "]";
          if (!e.is_table()) c.fail_at(&e, k, "expected a table {tau_s, gain_v_per_deg}, got " + describe(e));
          Section t = c.sub(*e.as_table(), k);
          CreepTerm term;
          t.number("tau_s", term.tau_s, positive);
          t.number("gain_v_per_deg", term.gain_v_per_deg);
          t.finish();
          se.creep.terms.push_back(term);
        }
      }
    });
    with_table(s, "acceleration_dependence", [&](Section& a) {
      a.boolean("enabled", se.acceleration_dependence.enabled);
      a.number("gain_v_per_rad_s2", se.acceleration_dependence.gain_v_per_rad_s2);
    });
    with_table(s, "drift", [&](Section& d) {
      d.boolean("enabled", se.drift.enabled);
      d.number("rate_v_per_hour", se.drift.rate_v_per_hour);
      d.number("random_walk_v_per_sqrt_hour", se.drift.random_walk_v_per_sqrt_hour, non_negative);
    });
    with_table(s, "memory_hysteresis", [&](Section& h) {
      auto& mh = se.memory_hysteresis;
      h.boolean("enabled", mh.enabled);
      h.choice("family", mh.family, {{"bouc_wen", MemoryHysteresisFamily::kBoucWen}, {"maxwell_slip", MemoryHysteresisFamily::kMaxwellSlip}});
      h.number("amplitude_v", mh.amplitude_v, amplitude_range);
      h.number("rate_sensitivity_s_per_rad", mh.rate_sensitivity_s_per_rad, rate_sensitivity_range);
      h.number("rate_filter_s", mh.rate_filter_s, non_negative);
      h.number("width_deg", mh.width_deg, width_range);
      h.number("shape", mh.shape, shape_range);
      h.number("beta_fraction", mh.beta_fraction, beta_fraction_range);
      const bool has_thresholds = h.get("thresholds_deg") != nullptr, has_weights = h.get("weights") != nullptr;
      h.numbers("thresholds_deg", mh.thresholds_deg, width_range);
      h.numbers("weights", mh.weights, non_negative);
      if (has_thresholds && mh.thresholds_deg.empty()) h.fail_at(h.get("thresholds_deg"), "thresholds_deg", "expected at least one threshold");
      if (has_thresholds && !has_weights) mh.weights.assign(mh.thresholds_deg.size(), 1.0);  // equal weights
      if (mh.weights.size() != mh.thresholds_deg.size())
        h.fail_at(h.get("weights"), "weights", "expected as many entries as thresholds_deg (" + std::to_string(mh.thresholds_deg.size()) + "), got " + std::to_string(mh.weights.size()));
      double wsum = 0;
      for (double w : mh.weights) wsum += w;
      if (!(wsum > 0)) h.fail_at(h.get("weights"), "weights", "expected at least one weight > 0");
    });
    with_table(s, "viscoelastic_lag", [&](Section& l) {
      l.boolean("enabled", se.viscoelastic_lag.enabled);
      l.number("tau_s", se.viscoelastic_lag.tau_s, lag_tau_range);
    });
  });

  with_table(top, "light", [&](Section& l) {
    LightSettings& li = sc.light;
    l.number("reference_level_v", li.reference_level_v, positive);
    with_table(l, "wander", [&](Section& w) {
      w.boolean("enabled", li.wander.enabled);
      w.number("sigma_rel", li.wander.sigma_rel, [](double x) { return x >= 0 && x < 0.3 ? std::string{} : std::string("a number in [0, 0.3)"); });
      w.number("tau_s", li.wander.tau_s, positive);
    });
    with_table(l, "steps", [&](Section& st) {
      st.boolean("enabled", li.steps.enabled);
      std::vector<double> at, rel;
      st.numbers("at_s", at, non_negative);
      st.numbers("relative_change", rel, [](double x) { return x > -0.9 && x < 10 ? std::string{} : std::string("a number in (-0.9, 10)"); });
      if (at.size() != rel.size())
        st.fail_at(st.get("relative_change"), "relative_change", "expected as many entries as at_s (" + std::to_string(at.size()) + "), got " + std::to_string(rel.size()));
      li.steps.steps.clear();
      for (std::size_t i = 0; i < at.size(); ++i) {
        if (i > 0 && at[i] < at[i - 1]) st.fail_at(st.get("at_s"), "at_s", "expected increasing times");
        li.steps.steps.push_back({at[i], rel[i]});
      }
    });
    with_table(l, "source_power_coupling", [&](Section& c) {
      c.boolean("enabled", li.source_power_coupling.enabled);
      c.number("sensor_exponent", li.source_power_coupling.sensor_exponent, [](double x) { return x > 0 && x < 5 ? std::string{} : std::string("a number in (0, 5)"); });
      c.number("reference_offset_v", li.source_power_coupling.reference_offset_v);
    });
  });

  with_table(top, "daq", [&](Section& d) {
    DaqSettings& q = sc.daq;
    d.choice("device", q.device, {{"usb6008", Device::kUsb6008}, {"usb6009", Device::kUsb6009}});
    d.choice("terminal", q.terminal, {{"rse", Terminal::kRse}, {"differential", Terminal::kDifferential}});
    d.number("range_v", q.range_v, positive);
    d.integer("bits", q.bits, 0, 24);
    d.number("scan_rate_hz", q.scan_rate_hz, [](double x) { return x > 0 && x <= 48000 ? std::string{} : std::string("a rate in (0, 48000] Hz"); });
    d.number("convert_interval_s", q.convert_interval_s, non_negative);
    d.boolean("multiplexed", q.multiplexed);
    if (const toml::node* n = d.get("order")) {
      const toml::array* a = n->as_array();
      if (a == nullptr || a->size() != kChannels)
        d.fail_at(n, "order", "expected an array of the 3 channel names, e.g. [\"sensor\", \"reference\", \"pot\"]");
      std::array<bool, kChannels> seen{};
      for (std::size_t i = 0; i < kChannels; ++i) {
        const toml::node& e = *a->get(i);
        const std::string k = "order[" + std::to_string(i) + "]";
        const auto name = e.value<std::string>();
        bool ok = false;
        for (const auto& [cn, cv] : kChannelNames) {
          if (name && *name == cn && !seen[static_cast<std::size_t>(cv)]) {
            q.order[i] = cv;
            seen[static_cast<std::size_t>(cv)] = true;
            ok = true;
          }
        }
        if (!ok) d.fail_at(&e, k, "expected 'sensor', 'reference' or 'pot', each once, got " + describe(e));
      }
    }
    with_table(d, "noise", [&](Section& n) {
      n.boolean("enabled", q.noise.enabled);
      n.number("sensor_v", q.noise.sensor_v, non_negative);
      n.number("reference_v", q.noise.reference_v, non_negative);
      n.number("pot_v", q.noise.pot_v, non_negative);
    });
    with_table(d, "periodic_interference", [&](Section& m) {
      m.boolean("enabled", q.periodic_interference.enabled);
      m.number("frequency_hz", q.periodic_interference.frequency_hz, positive);
      m.number("amplitude_v", q.periodic_interference.amplitude_v, non_negative);
      m.number("phase_deg", q.periodic_interference.phase_deg);
      m.number("third_harmonic_rel", q.periodic_interference.third_harmonic_rel, non_negative);
    });
    with_table(d, "time_delay", [&](Section& t) {
      t.boolean("enabled", q.time_delay.enabled);
      t.choice("channel", q.time_delay.channel, kChannelNames);
      t.number("delay_s", q.time_delay.delay_s, [](double x) { return x >= 0 && x <= 10 ? std::string{} : std::string("a delay in [0, 10] s"); });
    });
    if (q.terminal == Terminal::kRse && q.range_v != 10)
      d.fail_at(d.get("range_v"), "range_v", "expected 10 (RSE inputs of the USB-6008/6009 are +-10 V only), got " + fmt_num(q.range_v));
    if (q.terminal == Terminal::kDifferential) {
      static constexpr std::array<double, 8> kRanges{20, 10, 5, 4, 2.5, 2, 1.25, 1};
      bool ok = false;
      for (double r : kRanges) ok = ok || r == q.range_v;
      if (!ok) d.fail_at(d.get("range_v"), "range_v", "expected a differential range of the USB-6008/6009 (20, 10, 5, 4, 2.5, 2, 1.25 or 1 V), got " + fmt_num(q.range_v));
    }
  });

  const toml::node* traj = top.get("trajectory");
  if (traj == nullptr) top.fail_at(nullptr, "trajectory", "missing: add at least one [[trajectory]] segment");
  const toml::array* segs = traj->as_array();
  if (segs == nullptr || segs->empty()) top.fail_at(traj, "trajectory", "expected a non-empty array of [[trajectory]] tables");
  for (std::size_t i = 0; i < segs->size(); ++i) {
    const toml::node& e = *segs->get(i);
    const std::string k = "trajectory[" + std::to_string(i) + "]";
    if (!e.is_table()) top.fail_at(&e, k, "expected a table, got " + describe(e));
    Section s = top.sub(*e.as_table(), k);
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
    auto check = [&](const std::string& key, double v, const auto& rule) {
      const std::string want = std::isfinite(v) ? rule(v) : std::string("a finite number");
      if (!want.empty()) bad(k + key, "expected " + want + ", got " + fmt_num(v));
    };
    if (mh.family != MemoryHysteresisFamily::kBoucWen && mh.family != MemoryHysteresisFamily::kMaxwellSlip)
      bad(k + "family", "expected 'bouc_wen' or 'maxwell_slip'");
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
    check("viscoelastic_lag.tau_s", s.sensor.viscoelastic_lag.tau_s, lag_tau_range);
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
  toml::table root;
  try {
    root = toml::parse(toml_text, source);
  } catch (const toml::parse_error& e) {
    throw pof::ConfigError(source + ":" + std::to_string(e.source().begin.line) + ": TOML syntax error: " + pof::bound_quotes(e.description()));
  }
  Scenario sc = read_scenario(root, source);
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
