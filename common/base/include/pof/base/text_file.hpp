#pragma once
// Small text files read whole: calibration and potentiometer TOML, scenarios, DAQ configuration.
#include <cstddef>
#include <string>

namespace pof {

/// Longest such file read. Real ones are a few KiB; the bound keeps a wrong path (a recording, a
/// device such as /dev/zero) from being read into memory before the parser refuses it.
inline constexpr std::size_t kMaxTextFileBytes = 1u << 20;

/// The whole file at `path` (any kind of file: read until its end, at most `max_bytes`). `what`
/// names the expected content in the message ("calibration file"). Throws NoInputError (cannot
/// open, a directory), IoError (read error), ConfigError (longer than max_bytes).
std::string read_text_file(const std::string& path, const std::string& what, std::size_t max_bytes = kMaxTextFileBytes);

}  // namespace pof
