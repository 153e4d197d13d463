// Files of `pof gap` (see io.hpp).
#include "pof/gap/io.hpp"

#include <charconv>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <system_error>
#include <vector>

#include <toml++/toml.h>

#include "pof/io/errors.hpp"

namespace pof::gap {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t a = 0;
  while (true) {
    const std::size_t b = line.find(',', a);
    std::string_view f = line.substr(a, b == std::string_view::npos ? std::string_view::npos : b - a);
    while (!f.empty() && (f.front() == ' ' || f.front() == '\t')) f.remove_prefix(1);
    while (!f.empty() && (f.back() == ' ' || f.back() == '\t' || f.back() == '\r')) f.remove_suffix(1);
    out.push_back(f);
    if (b == std::string_view::npos) break;
    a = b + 1;
  }
  return out;
}

}  // namespace

io::Recording read_csv_recording(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw io::NoInputError(path.string() + ": cannot open the recording (missing or unreadable)");
  const std::string name = path.string();
  std::string line;
  std::size_t lineno = 0;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line[0] == '#') continue;
    for (auto f : split(line)) header.emplace_back(f);
    break;
  }
  if (header.empty()) throw io::DataError(name + ": empty file, expected a header t_s,sensor_v,reference_v,angle_ref_deg");
  auto col = [&](const std::string& c) -> int {
    for (std::size_t i = 0; i < header.size(); ++i)
      if (header[i] == c) return static_cast<int>(i);
    return -1;
  };
  const int ct = col("t_s"), cs = col("sensor_v"), cr = col("reference_v"), ca = col("angle_ref_deg"),
            cp = col("pot_v"), cg = col("angle_true_deg");
  for (auto [c, n] : {std::pair{ct, "t_s"}, {cs, "sensor_v"}, {cr, "reference_v"}})
    if (c < 0) throw io::DataError(name + ":" + std::to_string(lineno) + ": header lacks column '" + n +
                                   "' (expected t_s,sensor_v,reference_v,angle_ref_deg)");
  if (ca < 0)
    throw io::DataError(name + ":" + std::to_string(lineno) + ": header lacks column 'angle_ref_deg'" +
                        (cp >= 0 ? std::string(" (pot_v alone needs a potentiometer calibration, which `pof gap` does not take)")
                                 : std::string()));
  std::vector<double> t, s, r, a, g;
  const std::size_t need = static_cast<std::size_t>(std::max({ct, cs, cr, ca, cg})) + 1;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line == "\r" || line[0] == '#') continue;
    const auto f = split(line);
    if (f.size() < need)
      throw io::DataError(name + ":" + std::to_string(lineno) + ": expected " + std::to_string(header.size()) +
                          " fields, got " + std::to_string(f.size()));
    auto num = [&](int c) {
      double x = 0;
      const auto sv = f[static_cast<std::size_t>(c)];
      const auto res = std::from_chars(sv.data(), sv.data() + sv.size(), x);
      if (res.ec != std::errc() || res.ptr != sv.data() + sv.size() || !std::isfinite(x))
        throw io::DataError(name + ":" + std::to_string(lineno) + ": column " + header[static_cast<std::size_t>(c)] +
                            ": expected a number, got '" + std::string(sv) + "'");
      return x;
    };
    t.push_back(num(ct));
    s.push_back(num(cs));
    r.push_back(num(cr));
    a.push_back(num(ca));
    if (cg >= 0) g.push_back(num(cg));
  }
  if (in.bad()) throw io::IoError(name + ": read error after line " + std::to_string(lineno));
  io::Recording rec;
  rec.source = name;
  auto vec = [](const std::vector<double>& v) { return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()))); };
  rec.t_s = vec(t);
  rec.sensor_v = vec(s);
  rec.reference_v = vec(r);
  rec.angle_ref_deg = vec(a);
  if (cg >= 0) rec.angle_true_deg = vec(g);
  return rec;
}

void write_file_atomic(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw io::IoError(tmp.string() + ": cannot create file");
    out << text;
    out.flush();
    if (!out) throw io::IoError(tmp.string() + ": write failed");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw io::IoError(path.string() + ": cannot rename the temporary file into place");
  }
}

void write_csv_recording(const io::Recording& rec, const fs::path& path) {
  std::string out = "t_s,sensor_v,reference_v,angle_ref_deg,angle_true_deg\n";
  char buf[200];
  for (Eigen::Index i = 0; i < rec.size(); ++i) {
    const double g = rec.angle_true_deg.size() == rec.size() ? rec.angle_true_deg(i) : rec.angle_ref_deg(i);
    const int n = std::snprintf(buf, sizeof buf, "%.6f,%.6f,%.6f,%.5f,%.5f\n", rec.t_s(i), rec.sensor_v(i),
                                rec.reference_v(i), rec.angle_ref_deg(i), g);
    out.append(buf, static_cast<std::size_t>(n));
  }
  write_file_atomic(path, out);
}

namespace {

std::string model_toml(const Result& r, const std::string& source) {
  const json& m = r.model;
  toml::table t;
  t.insert("schema_version", 1);
  toml::table model{{"c1", m["c1"].get<double>()}, {"c2", m["c2"].get<double>()},
                    {"c9", m["c9"].get<double>()}, {"c10", m["c10"].get<double>()}};
  for (const char* d : {"flexion", "extension"}) {
    const auto& v = m[d];
    model.insert(d, toml::table{{"c3", v[0].get<double>()}, {"c4", v[1].get<double>()}, {"c5", v[2].get<double>()},
                                {"c6", v[3].get<double>()}, {"c7", v[4].get<double>()}, {"c8", v[5].get<double>()}});
  }
  t.insert("model", model);
  t.insert("normalisation", toml::table{{"reference_level_v", m["reference_level_v"].get<double>()}});
  toml::table gap{{"source", source},
                  {"baseline_gap_deg", r.baseline_gap_deg},
                  {"final_gap_deg", r.final_gap_deg},
                  {"delay_s", m["delay_s"].get<double>()},
                  {"duration_s", m["duration_s"].get<double>()}};
  toml::array terms;
  for (const auto& term : m["terms"]) {
    toml::array coef;
    for (const auto& c : term["coefficients_v"]) coef.push_back(c.get<double>());
    toml::table params;
    for (auto it = term["parameters"].begin(); it != term["parameters"].end(); ++it)
      params.insert(it.key(), it.value().get<double>());
    terms.push_back(toml::table{{"effect", term["effect"].get<std::string>()}, {"theta", term["theta"].get<double>()},
                                {"coefficients_v", coef}, {"parameters", params}});
  }
  gap.insert("terms", terms);
  t.insert("gap", gap);
  std::ostringstream o;
  o << "# Improved sensor model written by `pof gap` (docs/gap.md, \"model.toml\").\n"
       "# [model]: table-2 coefficients, c9 and c10 refitted (c1..c8 the paper's); reference_level_v the\n"
       "# level these apply at. [gap]: the accepted effect terms, added to the model voltage.\n"
    << t << '\n';
  return o.str();
}

std::string report_md(const Result& r, const std::string& source) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(3);
  o << "# Model gap report: " << source << "\n\n"
    << "Held-out RMS residual (time-blocked " << r.recording["folds"].get<std::size_t>() << "-fold CV) in degrees.\n\n"
    << "| step | effect | held-out gap [deg] | parameters |\n|---|---|---|---|\n"
    << "| 0 | baseline (paper model, c9/c10 refitted) | " << r.baseline_gap_deg << " | c9 = "
    << r.baseline["c9_deg_per_v"].get<double>() << " deg/V, c10 = " << r.baseline["c10_deg"].get<double>() << " deg |\n";
  int i = 1;
  for (const Step& s : r.steps) o << "| " << i++ << " | " << s.effect << " | " << s.gap_deg << " | `" << s.parameters.dump() << "` |\n";
  o << "\n**Baseline residual:** " << r.baseline["where"].get<std::string>() << "\n\n";
  i = 1;
  for (const Step& s : r.steps) {
    o << "## Step " << i++ << ": " << s.effect << "\n\n- where: " << s.where << "\n- held-out gap "
      << s.evidence["heldout_gap_before_deg"].get<double>() << " -> " << s.gap_deg << " deg ("
      << s.evidence["reduction_pct"].get<double>() << " %), delta BIC " << s.evidence["delta_bic"].get<double>()
      << ", runner-up " << s.evidence["runner_up"].get<std::string>() << "\n\n";
  }
  o << "## What is left\n\n" << (r.unexplained ? "Structure remains that no candidate explains" : "No significant structure left")
    << ": residual RMS / scan-to-scan noise floor = " << r.whiteness["rms_over_noise_floor"].get<double>()
    << ", Ljung-Box Q(20) = " << r.whiteness["ljung_box_q20"].get<double>() << " (5 % critical 31.41).\n"
    << "Final residual: " << r.whiteness["final_where"].get<std::string>() << "\n\n"
    << "![residual against time](residual_time.png)\n![residual against angle](residual_angle.png)\n"
    << "![residual against velocity](residual_velocity.png)\n![loops](loops.png)\n![gap per step](gap_steps.png)\n";
  return o.str();
}

}  // namespace

void write_outputs(const Result& r, const std::string& source, const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) throw io::IoError(dir.string() + ": cannot create the output directory: " + ec.message());
  json j = r.to_json();
  j["source"] = source;
  write_file_atomic(dir / "gap.json", j.dump(2) + "\n");
  write_file_atomic(dir / "model.toml", model_toml(r, source));
  std::string csv = "t_s,angle_deg,w_rad_s,v,model_baseline_v,model_final_v,resid_baseline_deg,resid_final_deg\n";
  char buf[256];
  const Series& s = r.series;
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    const int n = std::snprintf(buf, sizeof buf, "%.4f,%.4f,%.5f,%.6f,%.6f,%.6f,%.5f,%.5f\n", s.t[i], s.angle[i], s.w[i], s.v[i],
                                s.model_baseline[i], s.model_final[i], s.resid_baseline_deg[i], s.resid_final_deg[i]);
    csv.append(buf, static_cast<std::size_t>(n));
  }
  write_file_atomic(dir / "series.csv", csv);
  write_file_atomic(dir / "report.md", report_md(r, source));
}

}  // namespace pof::gap
