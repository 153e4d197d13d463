// fuzz-link: pof_io
// The calibration loader (common/io/include/pof/io/calibration_file.hpp): any text is either a
// ConfigError or a calibration that writes back (to_toml) to text the loader accepts and that
// writes back identically: what `pof calibrate` relies on when it validates before saving.
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_check.hpp"
#include "pof/io/calibration_file.hpp"
#include "pof/base/errors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  pof::io::CalibrationFile f;
  try {
    f = pof::io::parse_calibration(text, "fuzz.toml");
  } catch (const pof::ConfigError& e) {
    FUZZ_CHECK(std::string_view(e.what()).size() < 1024);
    return 0;
  }
  const std::string once = pof::io::to_toml(f);
  pof::io::CalibrationFile g;
  try {
    g = pof::io::parse_calibration(once, "fuzz.toml (written back)");
  } catch (const pof::ConfigError& e) {
    std::fprintf(stderr, "accepted, but its own output is refused: %s\n", e.what());
    FUZZ_CHECK(false);
  }
  FUZZ_CHECK(pof::io::to_toml(g) == once);
  return 0;
}
