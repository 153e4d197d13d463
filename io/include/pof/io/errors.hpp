#pragma once
// Typed setup-time errors. Each carries the exit code the CLI maps it to, so the message is written
// once, where the problem is found (naming the file, line, key or device), and main() only prints it.
// Never thrown on the streaming path (see ../shared/notes/style.md, "Errors").
#include <stdexcept>
#include <string>

#include "pof/io/exit_codes.hpp"

namespace pof::io {

class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& what) : std::runtime_error(what), code_(code) {}
  [[nodiscard]] ExitCode code() const noexcept { return code_; }

 private:
  ExitCode code_;
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

}  // namespace pof::io
