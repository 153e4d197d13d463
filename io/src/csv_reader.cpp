// CSV recording reader (format in recording_reader.hpp).
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pof/io/errors.hpp"
#include "pof/io/recording_reader.hpp"

namespace pof::io {

namespace {

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    std::string_view f = line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    while (!f.empty() && (f.front() == ' ' || f.front() == '\t')) f.remove_prefix(1);
    while (!f.empty() && (f.back() == ' ' || f.back() == '\t')) f.remove_suffix(1);
    out.push_back(f);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

std::optional<double> parse_number(std::string_view s) {
  if (s.empty()) return std::nullopt;
  if (s == "nan" || s == "NaN" || s == "NAN") return std::nan("");
  double v = 0;
  const char* first = s.data();
  if (*first == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

}  // namespace

Recording read_csv(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw NoInputError(path + ": cannot open: " + std::strerror(errno));
  Recording r;
  r.source = path;
  std::string line;
  long lineno = 0;
  std::vector<std::string> header;
  // Required and optional columns -> index in the header, -1 if absent.
  enum Col { kT, kSensor, kRef, kAngleRef, kPot, kAngleTrue, kNCols };
  const char* names[kNCols] = {"t_s", "sensor_v", "reference_v", "angle_ref_deg", "pot_v", "angle_true_deg"};
  int idx[kNCols] = {-1, -1, -1, -1, -1, -1};
  std::size_t n_fields = 0;
  std::vector<double> cols[kNCols];
  double last_t = -std::numeric_limits<double>::infinity();
  bool have_header = false;
  while (std::getline(in, line)) {
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    const auto f = split(line);
    const std::string where = path + ":" + std::to_string(lineno) + ": ";
    // Every writer we know ends rows with a newline; a last row without one was cut off mid-write
    // and may hold a shortened number that would otherwise parse.
    if (in.eof()) throw DataError(where + "last line has no newline: the file is truncated");
    if (!have_header) {
      have_header = true;
      n_fields = f.size();
      for (std::size_t i = 0; i < f.size(); ++i)
        for (int c = 0; c < kNCols; ++c)
          if (f[i] == names[c]) {
            if (idx[c] >= 0) throw DataError(where + "column '" + names[c] + "' appears twice in the header");
            idx[c] = static_cast<int>(i);
          }
      for (int c : {kT, kSensor, kRef})
        if (idx[c] < 0)
          throw DataError(where + "header has no column '" + names[c] +
                          "' (expected t_s,sensor_v,reference_v,angle_ref_deg or pot_v; got '" + line + "')");
      if (idx[kAngleRef] < 0 && idx[kPot] < 0)
        throw DataError(where + "header has neither 'angle_ref_deg' nor 'pot_v' (expected t_s,sensor_v,reference_v,angle_ref_deg or pot_v)");
      continue;
    }
    if (f.size() != n_fields)
      throw DataError(where + "expected " + std::to_string(n_fields) + " fields as in the header, got " +
                      std::to_string(f.size()));
    for (int c = 0; c < kNCols; ++c) {
      if (idx[c] < 0) continue;
      const std::string_view s = f[static_cast<std::size_t>(idx[c])];
      const auto v = parse_number(s);
      if (!v) throw DataError(where + "column " + names[c] + ": expected a number, got '" + std::string(s) + "'");
      if (c == kT) {
        if (!std::isfinite(*v)) throw DataError(where + "column t_s: expected a finite time, got '" + std::string(s) + "'");
        if (*v <= last_t)
          throw DataError(where + "column t_s: time " + std::string(s) + " does not increase (previous row " + std::to_string(last_t) + ")");
        last_t = *v;
      } else if (std::isinf(*v)) {
        throw DataError(where + "column " + names[c] + ": expected a finite number or nan, got '" + std::string(s) + "'");
      }
      cols[c].push_back(*v);
    }
  }
  if (in.bad()) throw IoError(path + ": read error after line " + std::to_string(lineno));
  if (!have_header) throw DataError(path + ":1: empty file, expected the header t_s,sensor_v,reference_v,angle_ref_deg");
  if (cols[kT].empty()) throw DataError(path + ":" + std::to_string(lineno + 1) + ": no data rows after the header");
  auto to_vec = [](const std::vector<double>& v) {
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
  };
  r.t_s = to_vec(cols[kT]);
  r.sensor_v = to_vec(cols[kSensor]);
  r.reference_v = to_vec(cols[kRef]);
  if (idx[kAngleRef] >= 0) r.angle_ref_deg = to_vec(cols[kAngleRef]);
  if (idx[kPot] >= 0) r.pot_v = to_vec(cols[kPot]);
  if (idx[kAngleTrue] >= 0) r.angle_true_deg = to_vec(cols[kAngleTrue]);
  return r;
}

Recording read_recording(const std::string& path, const std::string& lcm_channel) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw NoInputError(path + ": cannot open: " + std::strerror(errno));
  unsigned char magic[4] = {0, 0, 0, 0};
  in.read(reinterpret_cast<char*>(magic), 4);
  in.close();
  if (magic[0] == 0xED && magic[1] == 0xA1 && magic[2] == 0xDA && magic[3] == 0x01) return read_lcmlog(path, lcm_channel);
  return read_csv(path);
}

}  // namespace pof::io
