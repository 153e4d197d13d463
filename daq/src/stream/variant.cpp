// The protocol-variant bits a Backend reports (stream/backend.hpp), in words for the status
// message and the log.
#include "pof/daq/stream/backend.hpp"

namespace pof::daq {

std::string describe_variant(std::uint32_t bits) {
  std::string s;
  auto add = [&](std::uint32_t bit, const char* text) {
    if ((bits & bit) == 0U) return;
    if (!s.empty()) s += "; ";
    s += text;
  };
  add(kVariantHeader0000, "reply header 00 00");
  add(kVariantHeader0001, "reply header 00 01");
  add(kVariantBigEndian, "samples big-endian");
  add(kVariantLittleEndian, "samples little-endian");
  add(kVariantOrderUndecided,
      "sample byte order undecided: the signal has not told it (a steady input reads smooth both "
      "ways); blocks flagged doubtful until it moves or acquisition.sample_byte_order is set");
  add(kVariantLayoutRecordFirst, "report layout record-first (index at 102)");
  add(kVariantLayoutDataFirst, "report layout data-first (index at 101)");
  add(kVariantPaddingSet, "padding bits set in samples");
  add(kVariantReport104, "scan report 104 bytes (no record number)");
  add(kVariantSeScanOffset, "single-ended scan samples offset-coded (an AIn reading agreed)");
  add(kVariantSeScanTwos, "single-ended scan samples two's complement (an AIn reading agreed)");
  add(kVariantSeScanUndecided,
      "single-ended scan coding undecided: no AIn reading agreed (blocks flagged doubtful)");
  add(kVariantSoftwarePaced,
      "scan feature report refused (GET_REPORT fails): software-paced AIn reads, 45 reads/s over "
      "the channels (scan_rate_hz is the real rate)");
  return s;
}

}  // namespace pof::daq
