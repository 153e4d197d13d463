// CSV recording reader (format in recording_reader.hpp), and read_recording()'s format sniffing.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pof/base/errors.hpp"
#include "pof/io/lcmlog_scan.hpp"
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

// Lines of a file (any kind: a pipe or /dev/zero too) or of text in memory, each at most
// kMaxCsvLineBytes: memory stays bounded by the longest line allowed, not by the input.
class LineSource {
 public:
  LineSource(int fd, std::string name, std::string prefix) : fd_(fd), name_(std::move(name)), buf_(std::move(prefix)) {}
  LineSource(std::string_view text, std::string name) : name_(std::move(name)), mem_(text) {}

  /// The next line without its '\n'; `terminated` is false for a last line with no newline.
  /// False at the end of the input. Throws DataError when a line is too long, IoError on a read error.
  bool next(std::string_view& line, bool& terminated, long lineno) {
    if (fd_ < 0) return next_in(mem_, mem_pos_, line, terminated, lineno, true);
    for (;;) {
      if (next_in(buf_, pos_, line, terminated, lineno, eof_)) return true;
      if (eof_) return false;
      // Keep the unfinished line, read more.
      buf_.erase(0, pos_);
      pos_ = 0;
      const std::size_t at = buf_.size();
      buf_.resize(at + kChunk);
      ssize_t r = 0;
      do r = ::read(fd_, buf_.data() + at, kChunk);
      while (r < 0 && errno == EINTR);
      if (r < 0) throw IoError(name_ + ": read error after line " + std::to_string(lineno - 1) + ": " + std::strerror(errno));
      buf_.resize(at + static_cast<std::size_t>(r));
      eof_ = r == 0;
    }
  }

 private:
  static constexpr std::size_t kChunk = 64 * 1024;

  // A line of text[pos..] if complete (or the last one at the end); advances pos.
  bool next_in(std::string_view text, std::size_t& pos, std::string_view& line, bool& terminated, long lineno, bool at_end) {
    const std::size_t nl = text.find('\n', pos);
    const std::size_t len = (nl == std::string_view::npos ? text.size() : nl) - pos;
    if (len > kMaxCsvLineBytes)
      throw DataError(name_ + ":" + std::to_string(lineno) + ": line longer than " + std::to_string(kMaxCsvLineBytes) +
                      " bytes (starts '" + excerpt(text.substr(pos, kExcerptBytes + 1)) + "'): not a CSV recording");
    if (nl == std::string_view::npos) {
      if (!at_end || pos >= text.size()) return false;
      line = text.substr(pos);
      terminated = false;
      pos = text.size();
      return true;
    }
    line = text.substr(pos, len);
    terminated = true;
    pos = nl + 1;
    return true;
  }

  int fd_ = -1;
  std::string name_;
  std::string buf_;
  std::size_t pos_ = 0;
  bool eof_ = false;
  std::string_view mem_;
  std::size_t mem_pos_ = 0;
};

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

Recording parse_lines(LineSource& in, const std::string& path) {
  Recording r;
  r.source = path;
  std::string_view line;
  bool terminated = true;
  long lineno = 0;
  // Required and optional columns -> index in the header, -1 if absent.
  enum Col { kT, kSensor, kRef, kAngleRef, kPot, kAngleTrue, kNCols };
  const char* names[kNCols] = {"t_s", "sensor_v", "reference_v", "angle_ref_deg", "pot_v", "angle_true_deg"};
  int idx[kNCols] = {-1, -1, -1, -1, -1, -1};
  std::size_t n_fields = 0;
  std::vector<double> cols[kNCols];
  double last_t = -std::numeric_limits<double>::infinity();
  bool have_header = false;
  while (in.next(line, terminated, lineno + 1)) {
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty() || line[0] == '#') continue;
    const auto f = split(line);
    const std::string where = path + ":" + std::to_string(lineno) + ": ";
    // Every writer we know ends rows with a newline; a last row without one was cut off mid-write
    // and may hold a shortened number that would otherwise parse.
    if (!terminated) throw DataError(where + "last line has no newline: the file is truncated");
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
                          "' (expected t_s,sensor_v,reference_v,angle_ref_deg or pot_v; got '" + excerpt(line) + "')");
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
      if (!v) throw DataError(where + "column " + names[c] + ": expected a number, got '" + excerpt(s) + "'");
      if (c == kT) {
        if (!std::isfinite(*v)) throw DataError(where + "column t_s: expected a finite time, got '" + excerpt(s) + "'");
        if (*v <= last_t)
          throw DataError(where + "column t_s: time " + excerpt(s) + " does not increase (previous row " + std::to_string(last_t) + ")");
        last_t = *v;
      } else if (std::isinf(*v)) {
        throw DataError(where + "column " + names[c] + ": expected a finite number or nan, got '" + excerpt(s) + "'");
      }
      cols[c].push_back(*v);
    }
  }
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

// Opens `path` for reading; a directory is refused here (read(2) on it fails later, less clearly).
int open_input(const std::string& path, struct stat& st) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw NoInputError(path + ": cannot open: " + std::strerror(errno));
  if (::fstat(fd, &st) != 0 || S_ISDIR(st.st_mode)) {
    const int e = S_ISDIR(st.st_mode) ? EISDIR : errno;
    ::close(fd);
    throw NoInputError(path + ": cannot read: " + std::strerror(e));
  }
  return fd;
}

struct FdCloser {
  int fd;
  ~FdCloser() { ::close(fd); }
};

}  // namespace

Recording read_csv(const std::string& path) {
  struct stat st {};
  const FdCloser fd{open_input(path, st)};
  LineSource in(fd.fd, path, {});
  return parse_lines(in, path);
}

Recording parse_csv(std::string_view text, const std::string& name) {
  LineSource in(text, name);
  return parse_lines(in, name);
}

Recording read_recording(const std::string& path, const std::string& lcm_channel) {
  struct stat st {};
  const FdCloser fd{open_input(path, st)};
  // The first 4 bytes tell the format; on a pipe they cannot be read again, so they are handed on.
  std::string head(4, '\0');
  std::size_t got = 0;
  while (got < head.size()) {
    const ssize_t r = ::read(fd.fd, head.data() + got, head.size() - got);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) throw IoError(path + ": read error: " + std::strerror(errno));
    if (r == 0) break;
    got += static_cast<std::size_t>(r);
  }
  head.resize(got);
  const bool lcm = got == 4 && get_be32(reinterpret_cast<const unsigned char*>(head.data())) == kLcmLogSync;
  if (lcm && S_ISREG(st.st_mode)) return read_lcmlog(path, lcm_channel);
  if (lcm) {
    LcmLogReader log(path, fd.fd, std::vector<unsigned char>(head.begin(), head.end()));
    return read_lcmlog(log, lcm_channel);
  }
  LineSource in(fd.fd, path, std::move(head));
  return parse_lines(in, path);
}

}  // namespace pof::io
