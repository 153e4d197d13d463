// fuzz-link: pof_daq_protocol
// The MCC USB-1208LS protocol module (daq/include/pof/daq/protocol/mcc_usb1208ls.hpp), on arbitrary
// bytes read as what the device sends: 105-byte scan feature reports one after the other, and
// AIn input reports {lo, hi}. Properties:
//  - a scan report decodes, under either layout [7], to 64 counts within 12 bits, returns the index
//    scan_index() reads, and encode_scan_report() of the counts writes the report's data, index
//    (and record number) bytes back exactly;
//  - LayoutDetector, fed as the backend feeds it (reports that either layout may read as the next
//    index, from 1), decides only after kLayoutReports reports, for exactly one layout, and that
//    layout's index counted 1, 2, 3 ... over every report it accepted;
//  - AIn replies decode within the counts their coding can hold [5], to finite volts;
//  - the channel/gain queue reports [3] hold every channel given, or the channel list is refused.
// Seeds: tests/fuzz/corpus/mcc_usb1208ls/ (fuzz_seeds writes them).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

#include "fuzz_check.hpp"
#include "pof/daq/protocol/mcc_usb1208ls.hpp"

namespace mcc = pof::daq::mcc;

namespace {

constexpr mcc::ReportLayout kLayouts[] = {mcc::ReportLayout::kRecordFirst, mcc::ReportLayout::kDataFirst};

void report(mcc::ScanReport r) {
  for (const mcc::ReportLayout l : kLayouts) {
    std::array<std::int16_t, mcc::kSamplesPerScanReport> s{};
    const std::uint16_t index = mcc::decode_scan_report(r, s, l);
    FUZZ_CHECK(index == mcc::scan_index(r, l));
    for (const std::int16_t c : s) FUZZ_CHECK(c >= -2048 && c <= 2047);
    std::array<std::uint8_t, mcc::kScanReportBytes> again{};
    mcc::encode_scan_report(s, index, r[0], again, l);
    const std::size_t data = l == mcc::ReportLayout::kRecordFirst ? 1 : 0;
    const std::size_t at = l == mcc::ReportLayout::kRecordFirst ? 102 : 101;
    for (std::size_t i = data; i < data + 96; ++i) FUZZ_CHECK(again[i] == r[i]);
    FUZZ_CHECK(again[at] == r[at] && again[at + 1] == r[at + 1]);
    FUZZ_CHECK(data == 0 || again[0] == r[0]);
  }
}

void layout(const std::vector<mcc::ScanReport>& reports) {
  mcc::LayoutDetector d;
  std::vector<mcc::ScanReport> accepted;
  std::uint16_t expect = 1;
  for (const mcc::ScanReport& r : reports) {
    if (d.decided()) break;
    if (!d.is_next(r, expect)) continue;
    d.accept(r, expect);
    accepted.push_back(r);
    ++expect;
    FUZZ_CHECK(!d.decided() || accepted.size() >= mcc::LayoutDetector::kLayoutReports);
  }
  if (!d.decided()) return;
  const mcc::ReportLayout got = d.layout();
  const mcc::ReportLayout other = got == kLayouts[0] ? kLayouts[1] : kLayouts[0];
  bool other_counts = true;
  for (std::size_t i = 0; i < accepted.size(); ++i) {
    FUZZ_CHECK(mcc::scan_index(accepted[i], got) == i + 1);
    other_counts = other_counts && mcc::scan_index(accepted[i], other) == i + 1;
  }
  FUZZ_CHECK(!other_counts);  // decided for one layout: the other one's index did not count
}

void ain(std::span<const std::uint8_t> in) {
  for (std::size_t i = 0; i + 1 < in.size(); i += 2) {
    const std::int16_t diff = mcc::decode_ain_differential(in[i], in[i + 1]);
    const std::int16_t se = mcc::decode_ain_single_ended(in[i], in[i + 1]);
    FUZZ_CHECK(diff >= -2048 && diff <= 2047);
    // 11-bit offset binary by the source [5]; a reply with the top bits set reads as over range.
    FUZZ_CHECK(se >= -0x400 && se <= 0xFFF - 0x400);
    FUZZ_CHECK(std::isfinite(mcc::counts_to_volts(diff, mcc::kBp20V)) && std::isfinite(mcc::counts_to_volts(se, mcc::kSe10V)));
  }
}

void queue(std::span<const std::uint8_t> in) {
  // [count % 16] [gain] [channels]
  if (in.size() < 2) return;
  const std::span<const std::uint8_t> channels = in.subspan(2, std::min<std::size_t>(in[0] % 16U, in.size() - 2));
  const auto gain = static_cast<mcc::Gain>(in[1] & 0x78U);
  std::array<mcc::OutReport, 2> out{};
  std::size_t n = 0;
  try {
    n = mcc::load_queue_reports(channels, gain, out);
  } catch (const std::invalid_argument&) {
    FUZZ_CHECK(channels.empty() || channels.size() > 8);
    return;
  }
  FUZZ_CHECK(!channels.empty() && channels.size() <= 8 && n == (channels.size() > 6 ? 2U : 1U));
  // The first report counts the whole queue and holds up to 6 entries, the second the rest [3].
  FUZZ_CHECK(out[0][2] == channels.size() && (n == 1 || out[1][2] == channels.size() - 6));
  std::size_t k = 0;
  for (std::size_t r = 0; r < n; ++r) {
    FUZZ_CHECK(out[r][0] == 0 && out[r][1] == mcc::kALoadQueue);
    for (std::size_t i = 0; i < 6 && k < channels.size(); ++i, ++k) {
      FUZZ_CHECK(out[r][3 + i] == ((channels[k] & 7U) | gain | 0x80U));
    }
  }
  FUZZ_CHECK(k == channels.size());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<mcc::ScanReport> reports;
  for (std::size_t at = 0; at + mcc::kScanReportBytes <= size; at += mcc::kScanReportBytes) {
    reports.emplace_back(data + at, mcc::kScanReportBytes);
    report(reports.back());
  }
  layout(reports);
  ain({data, size});
  queue({data, size});
  return 0;
}
