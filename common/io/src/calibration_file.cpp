// Calibration TOML (layout in calibration_file.hpp). Parsed with toml++, validated key by key into
// a local value that is returned only when complete: a bad file never half-loads.
#include "pof/io/calibration_file.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <string_view>
#include <vector>

#include "pof/base/errors.hpp"
#include "pof/base/format.hpp"
#include "pof/base/text_file.hpp"
#include "pof/base/toml_reader.hpp"
#include "pof/io/atomic_file.hpp"

namespace pof::io {

namespace {

std::string num(double v) {
  std::string s = format_significant(v, 17);
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

std::string number_list(const double* v, int n) {
  std::string s = "[";
  for (int i = 0; i < n; ++i) s += (i ? ", " : "") + num(v[i]);
  return s + "]";
}

// A required array of at most `max` finite numbers, each satisfying `each`.
std::vector<double> numbers(TomlSection& s, std::string_view key, std::size_t max, const TomlCheck<double>& each = {}) {
  const TomlArray a = s.array(key);
  if (a.size() > max) a.fail("expected at most " + std::to_string(max) + " numbers, got " + std::to_string(a.size()));
  return a.values<double>(each);
}

// Two arrays that pair up element by element (thresholds and their weights, time constants and
// their gains): at most N each, copied into `first` and `second`. A length mismatch is reported on
// `second_key` as "expected one <one_per> (<count>)". Returns the number of pairs.
template <std::size_t N>
int paired_numbers(TomlSection& s, std::string_view first_key, const TomlCheck<double>& each, std::array<double, N>& first,
                   std::string_view second_key, std::array<double, N>& second, std::string_view one_per) {
  const auto a = numbers(s, first_key, N, each);
  const auto b = numbers(s, second_key, N);
  if (a.size() != b.size())
    s.fail(second_key, "expected one " + std::string(one_per) + " (" + std::to_string(a.size()) + ")");
  std::copy(a.begin(), a.end(), first.begin());
  std::copy(b.begin(), b.end(), second.begin());
  return static_cast<int>(a.size());
}

// [dynamic]: every key checked, array lengths consistent, then the model's own validity rule
// (one weight sign, positive thresholds and time constants) reported on the key it concerns.
pof::core::DynamicModel read_dynamic(TomlSection& d) {
  using pof::core::kMaxDegree;
  pof::core::DynamicModel m;
  m.degree = d.get<int>("degree", toml_check::integer_in(1, kMaxDegree));
  m.angle_centre_deg = d.get<double>("angle_centre_deg");
  m.angle_scale_deg = d.get<double>("angle_scale_deg", toml_check::positive());
  m.angle_min_deg = d.get<double>("angle_min_deg");
  m.angle_max_deg = d.get<double>("angle_max_deg");
  if (!(m.angle_max_deg > m.angle_min_deg)) d.fail("angle_max_deg", "must exceed dynamic.angle_min_deg");
  const auto poly = numbers(d, "poly", kMaxDegree + 1);
  if (poly.size() != static_cast<std::size_t>(m.degree + 1))
    d.fail("poly", "expected degree + 1 = " + std::to_string(m.degree + 1) + " coefficients, got " + std::to_string(poly.size()));
  std::copy(poly.begin(), poly.end(), m.poly.begin());
  m.n_operators = paired_numbers(d, "thresholds_deg", [](double v) { return v > 0 ? std::string{} : std::string("a threshold > 0 deg"); },
                                 m.threshold_deg, "weights_v_per_deg", m.weight_v_per_deg, "weight per threshold");
  m.rate_gain_s_per_rad = d.get<double>("rate_gain_s_per_rad");
  m.speed_filter_s = d.get<double>("speed_filter_s", toml_check::positive());
  m.speed_limit_rad_s = d.get<double>("speed_limit_rad_s", toml_check::positive());
  m.n_prony = paired_numbers(d, "prony_tau_s", [](double v) { return v > 0 ? std::string{} : std::string("a time constant > 0 s"); },
                             m.prony_tau_s, "prony_gain_v_per_deg", m.prony_gain_v_per_deg, "gain per time constant");
  // Files written before the bend lag existed have neither key: no lag.
  m.bend_lag_s = d.get_or("bend_lag_s", m.bend_lag_s);
  m.lag_window_s = d.get_or("lag_window_s", m.lag_window_s, toml_check::positive());
  if (const char* why = m.invalid_reason(); *why != '\0') d.fail(why);
  return m;
}

// [estimator]: both noises finite and > 0, reported on the key.
pof::core::EstimatorNoise read_estimator(TomlSection& e) {
  pof::core::EstimatorNoise n;
  n.voltage_noise_v = e.get<double>("voltage_noise_v", toml_check::positive());
  n.acceleration_noise_deg_s2 = e.get<double>("acceleration_noise_deg_s2", toml_check::positive());
  if (const char* why = n.invalid_reason(); *why != '\0') e.fail(why);
  return n;
}

// [gap] (docs/calibration.md, "`[gap]`: effect terms and how the compensator applies them"):
// every key typed and finite, unknown keys refused. Whether the compensator can apply the terms
// (drift, an unknown effect, counts, ranges) is gap_problems()'s question, asked by
// load_calibration(path, model, rate): a file with terms it cannot apply still parses, so `pof gap`
// can write and check whatever it found.
pof::core::GapModel read_gap(TomlSection& g) {
  pof::core::GapModel m;
  (void)g.schema_version({pof::core::kGapSchemaVersion});
  m.delay_s = g.get_or("delay_s", 0.0);
  m.backlash_deg = g.get_or("backlash_deg", 0.0);
  if (const std::optional<TomlArray> terms = g.find_array("terms")) {
    for (std::size_t i = 0; i < terms->size(); ++i) {
      TomlSection t = terms->section(i);
      pof::core::GapTerm term;
      term.line = t.line();
      term.effect = t.get<std::string>("effect");
      term.theta = t.get_or("theta", 0.0);
      term.coefficients_v = t.array("coefficients_v").values<double>();
      if (const auto r = t.find_array("thresholds_deg")) term.thresholds_deg = r->values<double>();
      if (const auto c = t.find_array("relay_centres_deg")) term.relay_centres_deg = c->values<double>();
      if (const auto tau = t.find_array("time_constants_s")) term.time_constants_s = tau->values<double>();
      t.with_section("parameters", [&](TomlSection& p) {
        for (const std::string& key : p.keys()) term.parameters.emplace_back(key, p.get<double>(key));
      });
      t.finish();
      m.terms.push_back(std::move(term));
    }
  }
  return m;
}

// A parameter name as a TOML key: bare when it can be, else quoted.
std::string toml_key(const std::string& k) {
  const bool bare = !k.empty() && std::all_of(k.begin(), k.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
  return bare ? k : quoted(k);
}

void write_gap(std::ostringstream& o, const pof::core::GapModel& g) {
  auto list = [](const std::vector<double>& v) { return number_list(v.data(), static_cast<int>(v.size())); };
  o << "\n[gap]    # effect terms found by `pof gap`, applied by the compensator (docs/calibration.md, \"[gap]\")\n"
    << "schema_version = " << pof::core::kGapSchemaVersion << "\n"
    << "delay_s = " << num(g.delay_s) << "    # time_delay: the sensor sees A(t - delay_s); 0 = none\n"
    << "backlash_deg = " << num(g.backlash_deg) << "    # backlash: belt play between the reference and the joint; 0 = none\n";
  for (const pof::core::GapTerm& t : g.terms) {
    o << "\n[[gap.terms]]\n"
      << "effect = " << quoted(t.effect) << "\n"
      << "theta = " << num(t.theta) << "\n"
      << "coefficients_v = " << list(t.coefficients_v) << "    # volts per unit of each basis function\n";
    if (!t.thresholds_deg.empty()) o << "thresholds_deg = " << list(t.thresholds_deg) << "\n";
    if (!t.relay_centres_deg.empty()) o << "relay_centres_deg = " << list(t.relay_centres_deg) << "\n";
    if (!t.time_constants_s.empty()) o << "time_constants_s = " << list(t.time_constants_s) << "\n";
    if (!t.parameters.empty()) {
      o << "[gap.terms.parameters]    # for humans; not applied\n";
      for (const auto& [name, value] : t.parameters) o << toml_key(name) << " = " << num(value) << "\n";
    }
  }
}

pof::core::PotentiometerCalibration read_potentiometer(TomlSection& s) {
  pof::core::PotentiometerCalibration p;
  p.deg_per_volt = s.get<double>("deg_per_volt", toml_check::non_zero());
  p.zero_v = s.get<double>("zero_v");
  if (const std::optional<TomlArray> offsets = s.find_array("offsets")) {
    for (std::size_t i = 0; i < offsets->size(); ++i) {
      const TomlArray pair = offsets->array(i);
      if (pair.size() != 2) offsets->fail(i, "expected [angle_deg, correction_deg]");
      const double angle = pair.get<double>(0), correction = pair.get<double>(1);
      if (!p.offsets.empty() && !(angle > p.offsets.back().first)) offsets->fail(i, "angles must increase");
      p.offsets.emplace_back(angle, correction);
    }
  }
  return p;
}

// The top-level keys of a calibration file other than [potentiometer] (parse_calibration reads
// them): a calibration file is also a potentiometer file (--pot-cal), and load_potentiometer
// leaves these to the calibration loader.
constexpr std::array<std::string_view, 13> kCalibrationOnlyKeys{
    "sensor_id", "date", "source_recording", "reference_level_v", "active_model", "model",
    "range", "fit_quality", "equations", "dynamic", "estimator", "held_out", "gap"};

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

std::string dynamic_fit_note(const pof::core::DynamicFitResult& fit) {
  if (!fit.chosen.constrained || !fit.unconstrained) return {};
  const auto& u = *fit.unconstrained;
  char b[400];
  if (fit.backwards_deg > 0)
    std::snprintf(b, sizeof b,
                  "fitted under the invertibility rule: unconstrained (degree %d, %d stop operators, CV %.3f deg) the output "
                  "runs backwards for %.2g deg after each reversal at rest, where one voltage stands for angles up to %.2g deg apart",
                  u.degree, u.n_operators, u.cv_rmse_deg, fit.backwards_deg, fit.backwards_ambiguity_deg);
  else
    std::snprintf(b, sizeof b,
                  "fitted under the invertibility rule: unconstrained (degree %d, %d stop operators, CV %.3f deg) the branch "
                  "after a reversal is monotone but too flat for the inverse's margin",
                  u.degree, u.n_operators, u.cv_rmse_deg);
  return b;
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
    o << "\n[dynamic]    # V = q(x) + phi(w) sum c_i S_i[theta] + sum g_j m_j (docs/calibration.md, \"The dynamic model\")\n";
    if (!f.dynamic_fit_note.empty()) o << "# " << f.dynamic_fit_note << "\n";
    o
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
  if (f.cal.estimator) {
    const auto& e = *f.cal.estimator;
    o << "\n[estimator]    # the dynamic model's angle estimated, not inverted (docs/calibration.md, \"The angle estimator\")\n"
      << "voltage_noise_v = " << num(e.voltage_noise_v) << "    # sigma_v: the normalised voltage's scatter in holds\n"
      << "acceleration_noise_deg_s2 = " << num(e.acceleration_noise_deg_s2) << "    # sigma_a: the motion model's white acceleration\n";
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
  if (f.cal.gap) write_gap(o, *f.cal.gap);
  return o.str();
}

void save_calibration(const CalibrationFile& f, const std::string& path) { write_file_atomic(path, to_toml(f)); }

CalibrationFile parse_calibration(const std::string& text, const std::string& name) {
  const toml::table t = parse_toml(text, name);
  TomlSection root(t, name);
  const int version = root.schema_version({1, 2, kCalibrationSchemaVersion});
  CalibrationFile f;
  f.sensor_id = root.get<std::string>("sensor_id");
  f.date = root.get<std::string>("date");
  f.source_recording = root.get<std::string>("source_recording");
  f.cal.reference_level_v = root.get<double>("reference_level_v", toml_check::positive());
  auto& m = f.cal.model;
  TomlSection model = root.section("model");
  m.c1 = model.get<double>("c1", toml_check::positive());
  m.c2 = model.get<double>("c2");
  m.c9 = model.get<double>("c9", toml_check::positive());  // the light falls as the knee bends: f5 has a negative slope
  m.c10 = model.get<double>("c10");
  TomlSection range = root.section("range");
  const auto knee_angle = toml_check::number_in(-30, 150);
  f.cal.angle_min_deg = range.get<double>("angle_min_deg", knee_angle);
  f.cal.angle_max_deg = range.get<double>("angle_max_deg", knee_angle);
  if (!(f.cal.angle_max_deg > f.cal.angle_min_deg))
    range.fail("angle_max_deg", "must exceed range.angle_min_deg (" + num(f.cal.angle_min_deg) + ")");
  f.cal.velocity_min_rad_s = range.get<double>("velocity_min_rad_s", toml_check::positive());
  f.cal.velocity_max_rad_s = range.get<double>("velocity_max_rad_s", toml_check::positive());
  if (!(f.cal.velocity_max_rad_s > f.cal.velocity_min_rad_s))
    range.fail("velocity_max_rad_s", "must exceed range.velocity_min_rad_s (" + num(f.cal.velocity_min_rad_s) + ")");
  if (f.cal.velocity_max_rad_s > 50) range.fail("velocity_max_rad_s", "above 50 rad/s is not a knee");
  range.finish();
  const double h_lo = pof::core::hysteresis_pct(m, f.cal.velocity_max_rad_s);
  const double h_hi = pof::core::hysteresis_pct(m, f.cal.velocity_min_rad_s);
  for (const char* direction : {"flexion", "extension"}) {
    TomlSection s = model.section(direction);
    auto& x = std::string_view(direction) == "flexion" ? m.flexion : m.extension;
    x.c3 = s.get<double>("c3");
    x.c4 = s.get<double>("c4");
    x.c5 = s.get<double>("c5");
    x.c6 = s.get<double>("c6");
    x.c7 = s.get<double>("c7");
    x.c8 = s.get<double>("c8");
    // f3 must keep the voltage's orientation over the calibrated hysteresis (a > 0) and f4 must
    // not collapse it (c7 > 0): otherwise eq. (11)/(12) cannot be inverted.
    for (const double h : {h_lo, h_hi})
      if (!(x.c3 * h + x.c4 > 0)) s.fail("c4", "f2 gives a = c3 h + c4 <= 0 at h = " + num(h) + " % (impossible gain)");
    if (!(x.c7 > 0)) s.fail("c7", "expected > 0, got " + num(x.c7));
    s.finish();
  }
  model.finish();
  TomlSection q = root.section("fit_quality");
  f.quality.sensitivity_v_per_deg = q.get<double>("sensitivity_v_per_deg");
  f.quality.linearity_r2 = q.get<double>("linearity_r2");
  if (f.quality.linearity_r2 > 1) q.fail("linearity_r2", "R^2 above 1");
  f.quality.f1_r2 = q.get<double>("f1_r2");
  f.quality.f1_rmse_pct = q.get<double>("f1_rmse_pct");
  f.quality.f4_flexion_r2 = q.get<double>("f4_flexion_r2");
  f.quality.f4_extension_r2 = q.get<double>("f4_extension_r2");
  f.quality.n_holds = q.get<std::int64_t>("n_holds");
  f.quality.n_velocity_tests = q.get<std::int64_t>("n_velocity_tests");
  q.finish();
  root.with_section("equations", [&](TomlSection& e) {
    f.equation_flexion = e.get_or<std::string>("flexion", "");
    f.equation_extension = e.get_or<std::string>("extension", "");
  });
  root.with_section("potentiometer", [&](TomlSection& p) { f.potentiometer = read_potentiometer(p); });
  if (version >= 2) {
    // Version 1 files hold the paper model only and keep it active.
    root.with_section("dynamic", [&](TomlSection& d) { f.cal.dynamic = read_dynamic(d); });
    const std::string active = root.get<std::string>("active_model");
    const auto kind = model_kind_of(active);
    if (!kind) root.fail("active_model", "expected \"paper\" or \"dynamic\", got \"" + excerpt(active) + "\"");
    f.cal.active = *kind;
    if (f.cal.active == pof::core::ModelKind::kDynamic && !f.cal.dynamic)
      root.fail("active_model", "is \"dynamic\" but the file has no [dynamic] section");
    root.with_section("held_out", [&](TomlSection& s) {
      HeldOutSummary h;
      h.paper_rmse_deg = s.get<double>("paper_rmse_deg");
      h.paper_p99_deg = s.get<double>("paper_p99_deg");
      h.dynamic_rmse_deg = s.get<double>("dynamic_rmse_deg");
      h.dynamic_p99_deg = s.get<double>("dynamic_p99_deg");
      h.folds = s.get<std::int64_t>("folds");
      f.held_out = h;
    });
  } else {
    for (const char* key : {"active_model", "dynamic", "held_out"})
      if (root.has(key)) root.fail(key, "is a schema_version 2 key, but the file says schema_version = 1");
  }
  if (version >= 3) root.with_section("estimator", [&](TomlSection& e) { f.cal.estimator = read_estimator(e); });
  else if (root.has("estimator"))
    root.fail("estimator", "is a schema_version 3 section, but the file says schema_version = " + std::to_string(version));
  if (f.cal.estimator && !f.cal.dynamic) root.fail("estimator", "needs a [dynamic] section: it estimates that model's angle");
  // The effect terms `pof gap` accepted (it writes this layout as its model.toml, docs/gap.md).
  root.with_section("gap", [&](TomlSection& g) { f.cal.gap = read_gap(g); });
  root.finish();
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

void require_applicable_gap(const CalibrationFile& f, const std::string& source, double scan_rate_hz) {
  if (!f.cal.gap) return;
  const std::vector<pof::core::GapProblem> problems = pof::core::gap_problems(*f.cal.gap, scan_rate_hz);
  if (problems.empty()) return;
  // Every term that cannot be applied, one line each: never silently skipped.
  std::string msg;
  for (const pof::core::GapProblem& p : problems) {
    if (!msg.empty()) msg += "\n";
    msg += source + (p.line > 0 ? ":" + std::to_string(p.line) : std::string()) + ": " + p.describe();
  }
  throw ConfigError(msg);
}

CalibrationFile load_calibration(const std::string& path, const std::string& model_choice, double scan_rate_hz) {
  CalibrationFile f = load_calibration(path);
  choose_model(f, model_choice, path);
  require_applicable_gap(f, path, scan_rate_hz);
  return f;
}

pof::core::PotentiometerCalibration load_potentiometer(const std::string& path) {
  const toml::table t = read_toml_file(path, "TOML file with a [potentiometer] section");
  TomlSection root(t, path);
  // A potentiometer file of its own need not say its version; a calibration file does.
  if (root.has("schema_version")) (void)root.schema_version({1, 2, kCalibrationSchemaVersion});
  std::optional<TomlSection> section = root.find_section("potentiometer");
  for (const std::string_view key : kCalibrationOnlyKeys) root.ignore(key);
  root.finish();
  if (!section) root.fail("potentiometer", "missing (expected a [potentiometer] table with deg_per_volt, zero_v)");
  const pof::core::PotentiometerCalibration p = read_potentiometer(*section);
  section->finish();
  return p;
}

}  // namespace pof::io
