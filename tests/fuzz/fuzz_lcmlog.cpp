// fuzz-link: pof_io
// The LCM log reader (common/io/include/pof/io/lcmlog_scan.hpp) and the recording reader on top of it
// (read_lcmlog: raw blocks on POF_RAW*). Any input must scan to events that lie inside it, never
// overlap and, with the damaged bytes, account for every byte; reading it as a recording either
// succeeds with consistent columns or is a DataError.
#include <cmath>
#include <cstdint>
#include <vector>

#include "fuzz_check.hpp"
#include "pof/base/errors.hpp"
#include "pof/io/lcmlog_scan.hpp"
#include "pof/io/recording_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::uint64_t event_bytes = 0;
  std::uint64_t last_end = 0;
  std::uint64_t events = 0;
  const pof::io::LcmLogScan s = pof::io::scan_lcmlog({data, size}, [&](const pof::io::LcmEventRef& e) {
    FUZZ_CHECK(e.offset >= last_end);
    FUZZ_CHECK(e.end() <= size);
    FUZZ_CHECK(!e.channel.empty() && e.channel.size() <= pof::io::kLcmLogMaxChannelBytes);
    FUZZ_CHECK(e.data == data + e.offset + pof::io::kLcmLogHeaderBytes + e.channel.size());
    event_bytes += e.end() - e.offset;
    last_end = e.end();
    ++events;
  });
  FUZZ_CHECK(events == s.events);
  FUZZ_CHECK(event_bytes + s.damaged_bytes == size);
  FUZZ_CHECK(s.clean() == (s.first_damage == size));
  FUZZ_CHECK(s.clean() == (s.damaged_regions == 0));
  FUZZ_CHECK(s.clean() || (!s.problem.empty() && s.damaged_regions <= s.damaged_bytes));
  FUZZ_CHECK(s.events_before_damage <= s.events);

  try {
    pof::io::LcmLogReader log("fuzz.lcmlog", std::vector<unsigned char>(data, data + size));
    const pof::io::Recording r = pof::io::read_lcmlog(log);
    FUZZ_CHECK(!log.damaged());
    const auto n = r.size();
    FUZZ_CHECK(r.sensor_v.size() == n && r.reference_v.size() == n);
    FUZZ_CHECK(r.angle_ref_deg.size() == n || r.pot_v.size() == n);
    for (Eigen::Index i = 1; i < n; ++i) FUZZ_CHECK(!(r.t_s[i] < r.t_s[i - 1]) || std::isnan(r.t_s[i]));
  } catch (const pof::DataError& e) {
    // The message quotes at most ~40 bytes of input, whatever the input.
    FUZZ_CHECK(std::string_view(e.what()).size() < 1024);
  }
  return 0;
}
