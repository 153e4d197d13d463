// Calibration TOML (layout in calibration_file.hpp). Parsed with toml++, validated key by key into
// a local value that is returned only when complete: a bad file never half-loads.
#include "pof/io/calibration_file.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <vector>

#include <toml++/toml.h>

#include "pof/io/atomic_file.hpp"
#include "pof/base/errors.hpp"
#include "pof/base/text_file.hpp"

namespace pof::io {

namespace {

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  std::string s = buf;
  // TOML needs a '.' or exponent for a float; "4" would read back as an integer (accepted, but
  // keep the file's types honest).
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

const char* type_name(toml::node_type t) {
  switch (t) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a float";
    case toml::node_type::boolean: return "a boolean";
    default: return "a date/time";
  }
}

// A TOML float or integer as a double (finiteness is the caller's check: the messages differ).
std::optional<double> numeric(const toml::node& n) {
  if (const auto* f = n.as_floating_point()) return f->get();
  if (const auto* i = n.as_integer()) return static_cast<double>(i->get());
  return std::nullopt;
}

class Keys {
 public:
  Keys(const toml::table& t, std::string name) : t_(t), name_(std::move(name)) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw ConfigError(name_ + ": key '" + key + "': " + what);
  }
  toml::node_view<const toml::node> node(const std::string& key) const {
    auto n = t_.at_path(key);
    if (!n) fail(key, "missing");
    return n;
  }
  double number(const std::string& key) const {
    const auto n = node(key);
    const std::optional<double> v = numeric(*n.node());
    if (!v) fail(key, std::string("expected a number, got ") + type_name(n.type()));
    if (!std::isfinite(*v)) fail(key, "expected a finite number, got " + num(*v));
    return *v;
  }
  double positive(const std::string& key) const {
    const double v = number(key);
    if (!(v > 0)) fail(key, "expected a number > 0, got " + num(v));
    return v;
  }
  std::int64_t integer(const std::string& key) const {
    const auto n = node(key);
    if (const auto* i = n.as_integer()) return i->get();
    fail(key, std::string("expected an integer, got ") + type_name(n.type()));
  }
  std::string string(const std::string& key, bool required = true) const {
    auto n = t_.at_path(key);
    if (!n) {
      if (required) fail(key, "missing");
      return {};
    }
    if (const auto* s = n.as_string()) return s->get();
    fail(key, std::string("expected a string, got ") + type_name(n.type()));
  }

 private:
  const toml::table& t_;
  std::string name_;
};

toml::table parse_toml(const std::string& text, const std::string& name) {
  try {
    return toml::parse(text, name);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    throw ConfigError(name + ":" + std::to_string(b.line) + ":" + std::to_string(b.column) + ": TOML syntax: " +
                      bound_quotes(e.description()));
  }
}

std::vector<double> numbers(const Keys& k, const toml::table& t, const std::string& key, std::size_t max) {
  auto n = t.at_path(key);
  if (!n) k.fail(key, "missing");
  const auto* arr = n.as_array();
  if (!arr) k.fail(key, std::string("expected an array of numbers, got ") + type_name(n.type()));
  if (arr->size() > max) k.fail(key, "expected at most " + std::to_string(max) + " numbers, got " + std::to_string(arr->size()));
  std::vector<double> out;
  for (std::size_t i = 0; i < arr->size(); ++i) {
    const std::optional<double> v = numeric((*arr)[i]);
    if (!v) k.fail(key + "[" + std::to_string(i) + "]", "expected a number");
    if (!std::isfinite(*v)) k.fail(key + "[" + std::to_string(i) + "]", "expected a finite number");
    out.push_back(*v);
  }
  return out;
}

std::string number_list(const double* v, int n) {
  std::string s = "[";
  for (int i = 0; i < n; ++i) s += (i ? ", " : "") + num(v[i]);
  return s + "]";
}

// [dynamic]: every key checked, array lengths consistent, then the model's own validity rule
// (one weight sign, positive thresholds and time constants) reported on the key it concerns.
pof::core::DynamicModel read_dynamic(const Keys& k, const toml::table& t) {
  using pof::core::kMaxDegree;
  using pof::core::kMaxOperators;
  using pof::core::kMaxPronyTerms;
  pof::core::DynamicModel m;
  const std::int64_t degree = k.integer("dynamic.degree");
  if (degree < 1 || degree > kMaxDegree) k.fail("dynamic.degree", "expected 1.." + std::to_string(kMaxDegree) + ", got " + std::to_string(degree));
  m.degree = static_cast<int>(degree);
  m.angle_centre_deg = k.number("dynamic.angle_centre_deg");
  m.angle_scale_deg = k.positive("dynamic.angle_scale_deg");
  m.angle_min_deg = k.number("dynamic.angle_min_deg");
  m.angle_max_deg = k.number("dynamic.angle_max_deg");
  if (!(m.angle_max_deg > m.angle_min_deg)) k.fail("dynamic.angle_max_deg", "must exceed dynamic.angle_min_deg");
  const auto poly = numbers(k, t, "dynamic.poly", kMaxDegree + 1);
  if (poly.size() != static_cast<std::size_t>(degree + 1))
    k.fail("dynamic.poly", "expected degree + 1 = " + std::to_string(degree + 1) + " coefficients, got " + std::to_string(poly.size()));
  std::copy(poly.begin(), poly.end(), m.poly.begin());
  const auto r = numbers(k, t, "dynamic.thresholds_deg", kMaxOperators);
  const auto c = numbers(k, t, "dynamic.weights_v_per_deg", kMaxOperators);
  if (r.size() != c.size()) k.fail("dynamic.weights_v_per_deg", "expected one weight per threshold (" + std::to_string(r.size()) + ")");
  m.n_operators = static_cast<int>(r.size());
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (!(r[i] > 0)) k.fail("dynamic.thresholds_deg[" + std::to_string(i) + "]", "expected a threshold > 0 deg");
    m.threshold_deg[i] = r[i];
    m.weight_v_per_deg[i] = c[i];
  }
  m.rate_gain_s_per_rad = k.number("dynamic.rate_gain_s_per_rad");
  m.speed_filter_s = k.positive("dynamic.speed_filter_s");
  m.speed_limit_rad_s = k.positive("dynamic.speed_limit_rad_s");
  const auto tau = numbers(k, t, "dynamic.prony_tau_s", kMaxPronyTerms);
  const auto g = numbers(k, t, "dynamic.prony_gain_v_per_deg", kMaxPronyTerms);
  if (tau.size() != g.size()) k.fail("dynamic.prony_gain_v_per_deg", "expected one gain per time constant (" + std::to_string(tau.size()) + ")");
  m.n_prony = static_cast<int>(tau.size());
  for (std::size_t j = 0; j < tau.size(); ++j) {
    if (!(tau[j] > 0)) k.fail("dynamic.prony_tau_s[" + std::to_string(j) + "]", "expected a time constant > 0 s");
    m.prony_tau_s[j] = tau[j];
    m.prony_gain_v_per_deg[j] = g[j];
  }
  // Files written before the bend lag existed have neither key: no lag.
  if (t.at_path("dynamic.bend_lag_s")) m.bend_lag_s = k.number("dynamic.bend_lag_s");
  if (t.at_path("dynamic.lag_window_s")) m.lag_window_s = k.positive("dynamic.lag_window_s");
  if (const char* why = m.invalid_reason(); *why != '\0') k.fail("dynamic", why);
  return m;
}

pof::core::PotentiometerCalibration read_potentiometer(const Keys& k, const toml::table& t) {
  pof::core::PotentiometerCalibration p;
  p.deg_per_volt = k.number("potentiometer.deg_per_volt");
  if (p.deg_per_volt == 0) k.fail("potentiometer.deg_per_volt", "must not be 0");
  p.zero_v = k.number("potentiometer.zero_v");
  if (auto offs = t.at_path("potentiometer.offsets")) {
    const auto* arr = offs.as_array();
    if (!arr) k.fail("potentiometer.offsets", std::string("expected an array of [angle_deg, correction_deg], got ") + type_name(offs.type()));
    for (std::size_t i = 0; i < arr->size(); ++i) {
      const std::string key = "potentiometer.offsets[" + std::to_string(i) + "]";
      const auto* pair = (*arr)[i].as_array();
      if (!pair || pair->size() != 2) k.fail(key, "expected [angle_deg, correction_deg]");
      double v[2];
      for (std::size_t j = 0; j < 2; ++j) {
        const std::optional<double> x = numeric((*pair)[j]);
        if (!x) k.fail(key, "expected two numbers");
        if (!std::isfinite(*x)) k.fail(key, "expected finite numbers");
        v[j] = *x;
      }
      if (!p.offsets.empty() && !(v[0] > p.offsets.back().first)) k.fail(key, "angles must increase");
      p.offsets.emplace_back(v[0], v[1]);
    }
  }
  return p;
}

}  // namespace

const char* to_string(pof::core::ModelKind k) { return k == pof::core::ModelKind::kDynamic ? "dynamic" : "paper"; }

std::optional<pof::core::ModelKind> model_kind_of(const std::string& text) {
  if (text == "paper") return pof::core::ModelKind::kPaper;
  if (text == "dynamic") return pof::core::ModelKind::kDynamic;
  return std::nullopt;
}

CalibrationFile make_calibration_file(const pof::core::CalibrationResult& r, const std::string& sensor_id,
                                      const std::string& source_recording, const std::string& date_utc) {
  CalibrationFile f;
  f.sensor_id = sensor_id;
  f.date = date_utc;
  f.source_recording = source_recording;
  f.cal = r.cal;
  f.quality.sensitivity_v_per_deg = std::abs(r.quasi_static.v_of_angle.slope);
  f.quality.linearity_r2 = r.quasi_static.v_of_angle.r2;
  f.quality.f1_r2 = r.f1.r2;
  f.quality.f1_rmse_pct = r.f1.rmse;
  f.quality.f4_flexion_r2 = r.f4_flexion.r2;
  f.quality.f4_extension_r2 = r.f4_extension.r2;
  f.quality.n_holds = r.quasi_static.hold_v.size();
  f.quality.n_velocity_tests = static_cast<std::int64_t>(r.tests.size());
  f.equation_flexion = format_combined_equation(r.eq11, pof::core::Direction::kFlexion);
  f.equation_extension = format_combined_equation(r.eq12, pof::core::Direction::kExtension);
  return f;
}

std::string to_toml(const CalibrationFile& f) {
  const auto& m = f.cal.model;
  std::ostringstream o;
  o << "# POF knee-angle sensor calibration (Leal-Junior et al. 2017, table 2). Written by pof calibrate.\n"
    << "schema_version = " << kCalibrationSchemaVersion << "\n"
    << "sensor_id = " << quoted(f.sensor_id) << "\n"
    << "date = " << quoted(f.date) << "\n"
    << "source_recording = " << quoted(f.source_recording) << "\n"
    << "# reference photodiode voltage at calibration time [V]: v = sensor_v * reference_level_v / reference_v\n"
    << "reference_level_v = " << num(f.cal.reference_level_v) << "\n"
    << "# the model the compensator runs: \"paper\" (eqs. (11)/(12)) or \"dynamic\" ([dynamic]); the lower\n"
    << "# held-out error chose it ([held_out]); pof compensate / pof-compensatord --model overrides it\n"
    << "active_model = " << quoted(to_string(f.cal.active)) << "\n";
  if (!f.dynamic_note.empty()) o << "# " << f.dynamic_note << "\n";
  o << "\n[model]    # the paper's model, table 2\n"
    << "c1 = " << num(m.c1) << "    # f1: h = c1 exp(c2 w) [%]\n"
    << "c2 = " << num(m.c2) << "    # [s/rad]\n"
    << "c9 = " << num(m.c9) << "    # f5: alpha = -c9 V2 + c10 [deg/V]\n"
    << "c10 = " << num(m.c10) << "    # [deg]\n";
  for (int d = 0; d < 2; ++d) {
    const auto& x = d == 0 ? m.flexion : m.extension;
    o << "\n[model." << (d == 0 ? "flexion" : "extension") << "]\n"
      << "c3 = " << num(x.c3) << "    # f2: a = c3 h + c4\n"
      << "c4 = " << num(x.c4) << "\n"
      << "c5 = " << num(x.c5) << "    # f2: b = c5 h + c6 [V]\n"
      << "c6 = " << num(x.c6) << "\n"
      << "c7 = " << num(x.c7) << "    # f4: V2 = c7 V1 - c8\n"
      << "c8 = " << num(x.c8) << "\n";
  }
  o << "\n[range]    # where the fit has data; outside it the compensator flags extrapolation\n"
    << "angle_min_deg = " << num(f.cal.angle_min_deg) << "\n"
    << "angle_max_deg = " << num(f.cal.angle_max_deg) << "\n"
    << "velocity_min_rad_s = " << num(f.cal.velocity_min_rad_s) << "\n"
    << "velocity_max_rad_s = " << num(f.cal.velocity_max_rad_s) << "\n"
    << "\n[fit_quality]\n"
    << "sensitivity_v_per_deg = " << num(f.quality.sensitivity_v_per_deg) << "\n"
    << "linearity_r2 = " << num(f.quality.linearity_r2) << "\n"
    << "f1_r2 = " << num(f.quality.f1_r2) << "\n"
    << "f1_rmse_pct = " << num(f.quality.f1_rmse_pct) << "\n"
    << "f4_flexion_r2 = " << num(f.quality.f4_flexion_r2) << "\n"
    << "f4_extension_r2 = " << num(f.quality.f4_extension_r2) << "\n"
    << "n_holds = " << f.quality.n_holds << "\n"
    << "n_velocity_tests = " << f.quality.n_velocity_tests << "\n"
    << "\n[equations]    # eq. (11)/(12) in the paper's form; informational, not read back\n"
    << "flexion = " << quoted(f.equation_flexion) << "\n"
    << "extension = " << quoted(f.equation_extension) << "\n";
  if (f.cal.dynamic) {
    const auto& d = *f.cal.dynamic;
    o << "\n[dynamic]    # V = q(x) + phi(w) sum c_i S_i[theta] + sum g_j m_j (docs/calibration.md, \"The dynamic model\")\n"
      << "degree = " << d.degree << "    # of the quasi-static polynomial q in x = (theta - centre) / scale\n"
      << "angle_centre_deg = " << num(d.angle_centre_deg) << "\n"
      << "angle_scale_deg = " << num(d.angle_scale_deg) << "\n"
      << "angle_min_deg = " << num(d.angle_min_deg) << "    # the identified range\n"
      << "angle_max_deg = " << num(d.angle_max_deg) << "\n"
      << "poly = " << number_list(d.poly.data(), d.degree + 1) << "    # q(x) = sum poly[k] x^k [V]\n"
      << "thresholds_deg = " << number_list(d.threshold_deg.data(), d.n_operators) << "    # stop operators r_i\n"
      << "weights_v_per_deg = " << number_list(d.weight_v_per_deg.data(), d.n_operators) << "    # c_i, one sign\n"
      << "rate_gain_s_per_rad = " << num(d.rate_gain_s_per_rad) << "    # kappa: phi = 1 + kappa w (>= 0), 1 / (1 - kappa w) (< 0)\n"
      << "speed_filter_s = " << num(d.speed_filter_s) << "\n"
      << "speed_limit_rad_s = " << num(d.speed_limit_rad_s) << "    # phi is held beyond this speed\n"
      << "prony_tau_s = " << number_list(d.prony_tau_s.data(), d.n_prony) << "\n"
      << "prony_gain_v_per_deg = " << number_list(d.prony_gain_v_per_deg.data(), d.n_prony) << "\n"
      << "bend_lag_s = " << num(d.bend_lag_s) << "    # tau_b: the fibre's bend lags the joint (0: none)\n"
      << "lag_window_s = " << num(d.lag_window_s) << "    # the online lag inverse's fitting window\n";
  }
  if (f.held_out) {
    const auto& h = *f.held_out;
    o << "\n[held_out]    # online angle vs reference on blocks held out of each fit; informational\n"
      << "paper_rmse_deg = " << num(h.paper_rmse_deg) << "\n"
      << "paper_p99_deg = " << num(h.paper_p99_deg) << "\n"
      << "dynamic_rmse_deg = " << num(h.dynamic_rmse_deg) << "\n"
      << "dynamic_p99_deg = " << num(h.dynamic_p99_deg) << "\n"
      << "folds = " << h.folds << "\n";
  }
  if (f.potentiometer) {
    const auto& p = *f.potentiometer;
    o << "\n[potentiometer]    # angle_deg = deg_per_volt * (pot_v - zero_v) + offset(angle)\n"
      << "deg_per_volt = " << num(p.deg_per_volt) << "\n"
      << "zero_v = " << num(p.zero_v) << "\n"
      << "offsets = [";
    for (std::size_t i = 0; i < p.offsets.size(); ++i)
      o << (i ? ", " : "") << "[" << num(p.offsets[i].first) << ", " << num(p.offsets[i].second) << "]";
    o << "]\n";
  }
  return o.str();
}

void save_calibration(const CalibrationFile& f, const std::string& path) { write_file_atomic(path, to_toml(f)); }

CalibrationFile parse_calibration(const std::string& text, const std::string& name) {
  const toml::table t = parse_toml(text, name);
  const Keys k(t, name);
  const std::int64_t version = k.integer("schema_version");
  if (version != 1 && version != kCalibrationSchemaVersion)
    k.fail("schema_version", "expected 1 or " + std::to_string(kCalibrationSchemaVersion) + ", got " + std::to_string(version));
  CalibrationFile f;
  f.sensor_id = k.string("sensor_id");
  f.date = k.string("date");
  f.source_recording = k.string("source_recording");
  f.cal.reference_level_v = k.positive("reference_level_v");
  auto& m = f.cal.model;
  m.c1 = k.positive("model.c1");
  m.c2 = k.number("model.c2");
  m.c9 = k.positive("model.c9");  // the light falls as the knee bends: f5 has a negative slope
  m.c10 = k.number("model.c10");
  f.cal.angle_min_deg = k.number("range.angle_min_deg");
  f.cal.angle_max_deg = k.number("range.angle_max_deg");
  if (f.cal.angle_min_deg < -30 || f.cal.angle_min_deg > 150) k.fail("range.angle_min_deg", "outside -30..150 deg");
  if (f.cal.angle_max_deg < -30 || f.cal.angle_max_deg > 150) k.fail("range.angle_max_deg", "outside -30..150 deg");
  if (!(f.cal.angle_max_deg > f.cal.angle_min_deg))
    k.fail("range.angle_max_deg", "must exceed range.angle_min_deg (" + num(f.cal.angle_min_deg) + ")");
  f.cal.velocity_min_rad_s = k.positive("range.velocity_min_rad_s");
  f.cal.velocity_max_rad_s = k.positive("range.velocity_max_rad_s");
  if (!(f.cal.velocity_max_rad_s > f.cal.velocity_min_rad_s))
    k.fail("range.velocity_max_rad_s", "must exceed range.velocity_min_rad_s (" + num(f.cal.velocity_min_rad_s) + ")");
  if (f.cal.velocity_max_rad_s > 50) k.fail("range.velocity_max_rad_s", "above 50 rad/s is not a knee");
  const double h_lo = pof::core::hysteresis_pct(m, f.cal.velocity_max_rad_s);
  const double h_hi = pof::core::hysteresis_pct(m, f.cal.velocity_min_rad_s);
  for (int d = 0; d < 2; ++d) {
    const std::string p = d == 0 ? "model.flexion." : "model.extension.";
    auto& x = d == 0 ? m.flexion : m.extension;
    x.c3 = k.number(p + "c3");
    x.c4 = k.number(p + "c4");
    x.c5 = k.number(p + "c5");
    x.c6 = k.number(p + "c6");
    x.c7 = k.number(p + "c7");
    x.c8 = k.number(p + "c8");
    // f3 must keep the voltage's orientation over the calibrated hysteresis (a > 0) and f4 must
    // not collapse it (c7 > 0): otherwise eq. (11)/(12) cannot be inverted.
    for (const double h : {h_lo, h_hi})
      if (!(x.c3 * h + x.c4 > 0)) k.fail(p + "c4", "f2 gives a = c3 h + c4 <= 0 at h = " + num(h) + " % (impossible gain)");
    if (!(x.c7 > 0)) k.fail(p + "c7", "expected > 0, got " + num(x.c7));
  }
  f.quality.sensitivity_v_per_deg = k.number("fit_quality.sensitivity_v_per_deg");
  f.quality.linearity_r2 = k.number("fit_quality.linearity_r2");
  if (f.quality.linearity_r2 > 1) k.fail("fit_quality.linearity_r2", "R^2 above 1");
  f.quality.f1_r2 = k.number("fit_quality.f1_r2");
  f.quality.f1_rmse_pct = k.number("fit_quality.f1_rmse_pct");
  f.quality.f4_flexion_r2 = k.number("fit_quality.f4_flexion_r2");
  f.quality.f4_extension_r2 = k.number("fit_quality.f4_extension_r2");
  f.quality.n_holds = k.integer("fit_quality.n_holds");
  f.quality.n_velocity_tests = k.integer("fit_quality.n_velocity_tests");
  f.equation_flexion = k.string("equations.flexion", false);
  f.equation_extension = k.string("equations.extension", false);
  if (t.contains("potentiometer")) f.potentiometer = read_potentiometer(k, t);
  if (version >= 2) {
    // Version 1 files hold the paper model only and keep it active.
    if (t.contains("dynamic")) f.cal.dynamic = read_dynamic(k, t);
    const std::string active = k.string("active_model");
    const auto kind = model_kind_of(active);
    if (!kind) k.fail("active_model", "expected \"paper\" or \"dynamic\", got \"" + excerpt(active) + "\"");
    f.cal.active = *kind;
    if (f.cal.active == pof::core::ModelKind::kDynamic && !f.cal.dynamic)
      k.fail("active_model", "is \"dynamic\" but the file has no [dynamic] section");
    if (t.contains("held_out")) {
      HeldOutSummary h;
      h.paper_rmse_deg = k.number("held_out.paper_rmse_deg");
      h.paper_p99_deg = k.number("held_out.paper_p99_deg");
      h.dynamic_rmse_deg = k.number("held_out.dynamic_rmse_deg");
      h.dynamic_p99_deg = k.number("held_out.dynamic_p99_deg");
      h.folds = k.integer("held_out.folds");
      f.held_out = h;
    }
  }
  return f;
}

CalibrationFile load_calibration(const std::string& path) { return parse_calibration(read_text_file(path, "calibration file"), path); }

void choose_model(CalibrationFile& f, const std::string& choice, const std::string& source) {
  if (choice.empty() || choice == "file") return;
  const auto kind = model_kind_of(choice);
  if (!kind) throw ConfigError(source + ": --model: expected file, paper or dynamic, got \"" + excerpt(choice) + "\"");
  f.cal.active = *kind;
  if (f.cal.active == pof::core::ModelKind::kDynamic && !f.cal.dynamic)
    throw ConfigError(source + ": --model dynamic: the file has no [dynamic] section (recalibrate with pof calibrate)");
}

CalibrationFile load_calibration(const std::string& path, const std::string& model_choice) {
  CalibrationFile f = load_calibration(path);
  choose_model(f, model_choice, path);
  return f;
}

pof::core::PotentiometerCalibration load_potentiometer(const std::string& path) {
  const toml::table t = parse_toml(read_text_file(path, "TOML file with a [potentiometer] section"), path);
  const Keys k(t, path);
  if (!t.contains("potentiometer")) k.fail("potentiometer", "missing (expected a [potentiometer] table with deg_per_volt, zero_v)");
  return read_potentiometer(k, t);
}

}  // namespace pof::io
