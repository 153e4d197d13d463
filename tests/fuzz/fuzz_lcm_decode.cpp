// libFuzzer target: arbitrary bytes into the bounded decoder of every pofkit type
// (lcmtypes/include/pof/lcm/decode.hpp), which the receivers run on everything off the bus.
// Properties: decode<T>() never throws, crashes or reads out of bounds (ASan), never allocates more
// than its budget (run with -malloc_limit_mb / -rss_limit_mb), and what it accepts is exactly what
// lcm-gen's encoder writes back for the decoded message, byte for byte. Decoding into a message
// reused across inputs (as pof::bus::Receiver does) gives the same message as a fresh one.
// Seeds: tests/fuzz/corpus/lcm_decode/ (one valid message of each type).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "pof/lcm/decode.hpp"

namespace {

template <class T>
void one(const uint8_t* data, size_t size, T& reused) {
  T fresh{};
  const pof::lcmutil::DecodeResult a = pof::lcmutil::decode(data, size, fresh);
  const pof::lcmutil::DecodeResult b = pof::lcmutil::decode(data, size, reused);
  if (static_cast<bool>(a) != static_cast<bool>(b) || a.error != b.error) std::abort();
  if (!a) {
    (void)a.describe();  // the error text is built from the result alone, never from the bytes
    return;
  }
  const int n = fresh.getEncodedSize();
  if (n < 8 || static_cast<size_t>(n) != size) std::abort();
  std::vector<uint8_t> out(size), again(size);
  if (fresh.encode(out.data(), 0, n) != n || reused.encode(again.data(), 0, n) != n) std::abort();
  if (std::memcmp(out.data(), data, size) != 0 || out != again) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static pof::raw_block_t raw;
  static pof::angle_t angle;
  static pof::cycle_stats_t cycle;
  static pof::daq_status_t daq;
  static pof::compensator_status_t comp;
  one(data, size, raw);
  one(data, size, angle);
  one(data, size, cycle);
  one(data, size, daq);
  one(data, size, comp);
  return 0;
}
