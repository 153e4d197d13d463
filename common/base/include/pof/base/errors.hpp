#pragma once
// Typed setup-time errors. Each carries the exit code the CLI maps it to, so the message is written
// once, where the problem is found (naming the file, line, key or device), and main() only prints it.
// Never thrown on the streaming path (docs/architecture.md, "Errors").
#include <stdexcept>
#include <string>
#include <string_view>

#include "pof/base/exit_codes.hpp"

namespace pof {

class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& what) : std::runtime_error(what), code_(code) {}
  [[nodiscard]] ExitCode code() const noexcept { return code_; }

 private:
  ExitCode code_;
};

/// Bad command line found after parsing (exit 2), e.g. an output path that is one of the inputs.
struct UsageError : Error {
  explicit UsageError(const std::string& what) : Error(kExitUsage, what) {}
};
/// Malformed input data (exit 65), e.g. "run.csv:17: column sensor_v: expected a number, got 'x'".
struct DataError : Error {
  explicit DataError(const std::string& what) : Error(kExitDataErr, what) {}
};
/// Input missing or unreadable (exit 66).
struct NoInputError : Error {
  explicit NoInputError(const std::string& what) : Error(kExitNoInput, what) {}
};
/// Failure while reading or writing (exit 74).
struct IoError : Error {
  explicit IoError(const std::string& what) : Error(kExitIoErr, what) {}
};
/// Bad configuration or calibration (exit 78), e.g. "cal.toml: key 'quasi_static.c9': expected a
/// finite number".
struct ConfigError : Error {
  explicit ConfigError(const std::string& what) : Error(kExitConfig, what) {}
};

/// Longest piece of input an error message quotes: a damaged file must not put megabytes on one
/// stderr line (a CSV without newlines is one "line").
inline constexpr std::size_t kExcerptBytes = 40;

/// `text` for an error message: at most kExcerptBytes bytes of it, then "…" when cut; bytes that are
/// not printable ASCII are written \xNN (a NUL or an escape sequence must not reach a terminal),
/// and a cut never splits such an escape.
inline std::string excerpt(std::string_view text) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  std::size_t used = 0;
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    const bool printable = c >= 0x20 && c < 0x7f;
    const std::size_t cost = printable ? 1 : 4;
    if (used + cost > kExcerptBytes) return out + "\u2026";
    if (printable) {
      out += ch;
    } else {
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
    used += cost;
  }
  return out;
}

/// A parser's message (toml++ quotes the key or text it choked on, up to ~500 bytes) with every
/// '...' quotation passed through excerpt(); an unterminated one runs to the end.
inline std::string bound_quotes(std::string_view message) {
  std::string out;
  std::size_t pos = 0;
  while (pos < message.size()) {
    const std::size_t open = message.find('\'', pos);
    if (open == std::string_view::npos) break;
    std::size_t close = message.find('\'', open + 1);
    if (close == std::string_view::npos) close = message.size();
    out.append(message.substr(pos, open + 1 - pos));
    out += excerpt(message.substr(open + 1, close - open - 1));
    if (close < message.size()) out += '\'';
    pos = close + 1;
  }
  if (pos < message.size()) out.append(message.substr(pos));
  return out;
}

}  // namespace pof
