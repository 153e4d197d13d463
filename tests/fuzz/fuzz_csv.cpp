// fuzz-link: pof_io
// The CSV recording reader (common/io/src/csv_reader.cpp): any text either reads as a recording whose
// columns have one length and whose times are finite and increasing, or is a DataError naming the
// file and a line, with a bounded message.
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_check.hpp"
#include "pof/base/errors.hpp"
#include "pof/io/recording_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const pof::io::Recording r = pof::io::parse_csv(text, "fuzz.csv");
    const auto n = r.size();
    FUZZ_CHECK(n > 0);
    FUZZ_CHECK(r.sensor_v.size() == n && r.reference_v.size() == n);
    FUZZ_CHECK(r.angle_ref_deg.size() == n || r.pot_v.size() == n);
    for (Eigen::Index i = 0; i < n; ++i) {
      FUZZ_CHECK(std::isfinite(r.t_s[i]));
      if (i > 0) FUZZ_CHECK(r.t_s[i] > r.t_s[i - 1]);
    }
  } catch (const pof::DataError& e) {
    const std::string_view what = e.what();
    FUZZ_CHECK(what.rfind("fuzz.csv:", 0) == 0);
    FUZZ_CHECK(what.size() < 512);
  }
  return 0;
}
