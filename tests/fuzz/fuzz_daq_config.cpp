// fuzz-link: pof_daq_stream
// The pof-daqd configuration loader (daq/include/pof/daq/stream/config.hpp): any text is a TOML syntax error, a
// ConfigError, or a configuration whose --print-config output (to_toml) loads back to the same
// output.
#include <cstdint>
#include <string>
#include <string_view>

#include <toml++/toml.h>

#include "pof/daq/stream/config.hpp"
#include "fuzz_check.hpp"
#include "pof/base/errors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::string once;
  try {
    const toml::table t = toml::parse(text, std::string_view{"fuzz.toml"});
    once = pof::daq::to_toml(pof::daq::config_from_table(t, "fuzz.toml"));
  } catch (const toml::parse_error&) {
    return 0;
  } catch (const pof::ConfigError& e) {
    FUZZ_CHECK(std::string_view(e.what()).size() < 1024);
    return 0;
  }
  try {
    const toml::table t = toml::parse(std::string_view{once}, std::string_view{"written back"});
    FUZZ_CHECK(pof::daq::to_toml(pof::daq::config_from_table(t, "written back")) == once);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "accepted, but its own --print-config output is refused: %s\n", e.what());
    FUZZ_CHECK(false);
  }
  return 0;
}
