// MCC USB-1208LS protocol: see the numbered block comment in mcc_usb1208ls.hpp.
#include "pof/daq/protocol/mcc_usb1208ls.hpp"

#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace pof::daq::mcc {

std::optional<Gain> gain_for(bool differential, double range_v) {
  if (!differential) {
    if (std::abs(range_v - 10.0) < 1e-9) return kSe10V;
    return std::nullopt;
  }
  struct G {
    double v;
    Gain g;
  };
  static constexpr G kTable[] = {{20, kBp20V}, {10, kBp10V},  {5, kBp5V},     {4, kBp4V},
                                 {2.5, kBp2_5V}, {2, kBp2V}, {1.25, kBp1_25V}, {1, kBp1V}};
  for (const auto& e : kTable) {
    if (std::abs(e.v - range_v) < 1e-9) return e.g;
  }
  return std::nullopt;
}

double gain_range_v(Gain g) {
  switch (g) {
    case kSe10V: return 10.0;
    case kBp20V: return 20.0;
    case kBp10V: return 10.0;
    case kBp5V: return 5.0;
    case kBp4V: return 4.0;
    case kBp2_5V: return 2.5;
    case kBp2V: return 2.0;
    case kBp1_25V: return 1.25;
    case kBp1V: return 1.0;
  }
  return 10.0;
}

OutReport ain_report(std::uint8_t channel, Gain gain) {
  return OutReport{0, kAIn, channel, gain, 0, 0, 0, 0, 0};
}

std::size_t load_queue_reports(std::span<const std::uint8_t> channels, Gain gain,
                               std::array<OutReport, 2>& out) {
  const std::size_t n = channels.size();
  // Two reports of 6 entries would hold 12, but the device's queue holds 8 [3]: a longer list
  // would be refused by it, and one beyond 12 would not fit `out`.
  if (n == 0 || n > 8) throw std::invalid_argument("USB-1208LS channel/gain queue: 1 to 8 channels, not " + std::to_string(n));
  out = {};
  out[0][1] = kALoadQueue;
  out[0][2] = static_cast<std::uint8_t>(n);
  const std::size_t first = n > 6 ? 6 : n;
  for (std::size_t i = 0; i < first; ++i) {
    out[0][3 + i] = static_cast<std::uint8_t>((channels[i] & 0x7U) | gain | 0x80U);
  }
  if (n <= 6) return 1;
  out[1][1] = kALoadQueue;
  out[1][2] = static_cast<std::uint8_t>(n - 6);
  for (std::size_t i = 6; i < n; ++i) {
    out[1][3 + i - 6] = static_cast<std::uint8_t>((channels[i] & 0x7U) | gain | 0x80U);
  }
  return 2;
}

OutReport ain_stop_report() { return OutReport{0, kAInStop, 0, 0, 0, 0, 0, 0, 0}; }

std::optional<ScanTimer> scan_timer(double rate) {
  struct Band {
    double lo, hi;
    std::uint8_t prescale, setup;
  };
  static constexpr Band kBands[] = {{100, 200, 7, 0},   {200, 400, 6, 0},    {400, 800, 5, 0},
                                    {800, 1500, 4, 1},  {1500, 3000, 3, 3},  {3000, 6000, 2, 6},
                                    {6000, 8192, 1, 10}};
  for (const auto& b : kBands) {
    if (rate >= b.lo && rate < b.hi) {
      const double mult = static_cast<double>(1U << (b.prescale + 1U));
      const double timer = std::round(256.0 - kClockHz / (rate * mult));
      const double actual = kClockHz / (mult * (256.0 - timer));
      return ScanTimer{b.prescale, static_cast<std::uint8_t>(timer + b.setup), actual};
    }
  }
  return std::nullopt;
}

OutReport ain_scan_report(std::uint16_t count, const ScanTimer& t, std::uint8_t options) {
  return OutReport{0,         kAInScan, static_cast<std::uint8_t>(count & 0xFF),
                   static_cast<std::uint8_t>(count >> 8), t.preload, t.prescale, options, 0, 0};
}

std::int16_t decode_ain_differential(std::uint8_t lo, std::uint8_t hi) {
  const auto raw = static_cast<std::int16_t>(static_cast<std::uint16_t>((hi << 8) | (lo << 4)));
  return static_cast<std::int16_t>(raw / 16);
}

std::int16_t decode_ain_single_ended(std::uint8_t lo, std::uint8_t hi) {
  return static_cast<std::int16_t>(((hi << 4) | (lo & 0x0F)) - 0x400);
}

std::size_t queue_length(std::size_t n) {
  for (std::size_t q : {1U, 2U, 4U, 8U}) {
    if (n <= q) return q;
  }
  return 0;
}

int full_scale_counts(Gain gain) { return gain == kSe10V ? 0x3FF : 0x7FF; }

double counts_to_volts(std::int16_t counts, Gain gain) {
  return counts * gain_range_v(gain) / full_scale_counts(gain);
}

double scan_counts_to_volts(std::int16_t counts, Gain gain) { return counts_to_volts(counts, gain); }

const char* layout_name(ReportLayout l) {
  return l == ReportLayout::kRecordFirst ? "record-first (index at 102)" : "data-first (index at 101)";
}

std::optional<ReportLayout> layout_for_size(std::size_t wire_bytes) {
  if (wire_bytes == kScanReportBytesNoRecord) return ReportLayout::kDataFirst;
  return std::nullopt;
}

bool is_scan_report_size(std::size_t wire_bytes) {
  return wire_bytes == kScanReportBytes || wire_bytes == kScanReportBytesNoRecord;
}

namespace {
std::int16_t sign12(unsigned v) {
  return static_cast<std::int16_t>((v & 0x800U) != 0U ? static_cast<int>(v) - 0x1000 : static_cast<int>(v));
}
}  // namespace

unsigned scan_field12(std::int16_t decoded) { return static_cast<unsigned>(decoded) & 0xFFFU; }

std::int16_t se_scan_counts(unsigned field12, SeScanCoding c) {
  field12 &= 0xFFFU;
  return c == SeScanCoding::kOffset ? static_cast<std::int16_t>(static_cast<int>(field12) - 0x400)
                                    : sign12(field12);
}

std::optional<SeScanCoding> se_scan_coding_from(std::int16_t ain_counts, unsigned field12, int tolerance) {
  const int d_twos = std::abs(se_scan_counts(field12, SeScanCoding::kTwosComplement) - ain_counts);
  const int d_off = std::abs(se_scan_counts(field12, SeScanCoding::kOffset) - ain_counts);
  const bool twos = d_twos <= tolerance;
  const bool off = d_off <= tolerance;
  if (twos == off) return std::nullopt;
  return twos ? SeScanCoding::kTwosComplement : SeScanCoding::kOffset;
}

namespace {
std::size_t data_at(ReportLayout l) { return l == ReportLayout::kRecordFirst ? 1 : 0; }
std::size_t index_at(ReportLayout l) { return l == ReportLayout::kRecordFirst ? 102 : 101; }
}  // namespace

std::uint16_t scan_index(ScanReport r, ReportLayout l) {
  const std::size_t i = index_at(l);
  return static_cast<std::uint16_t>(r[i] | (r[i + 1] << 8));
}

std::uint16_t decode_scan_report(ScanReport r, std::span<std::int16_t, kSamplesPerScanReport> s,
                                 ReportLayout l) {
  const std::uint8_t* d = &r[data_at(l)];
  for (std::size_t i = 0, k = 0; i < 96; i += 3, k += 2) {
    s[k] = sign12(d[i] | ((d[i + 1] & 0xF0U) << 4));
    s[k + 1] = sign12(d[i + 2] | ((d[i + 1] & 0x0FU) << 8));
  }
  return scan_index(r, l);
}

bool LayoutDetector::is_next(ScanReport r, std::uint16_t expect) const {
  for (int k = 0; k < 2; ++k) {
    if (possible_[k] && scan_index(r, static_cast<ReportLayout>(k)) == expect) return true;
  }
  return false;
}

void LayoutDetector::accept(ScanReport r, std::uint16_t expect) {
  for (int k = 0; k < 2; ++k) {
    if (scan_index(r, static_cast<ReportLayout>(k)) != expect) possible_[k] = false;
  }
  ++seen_;
}

void LayoutDetector::force(ReportLayout l) {
  possible_[0] = l == ReportLayout::kRecordFirst;
  possible_[1] = l == ReportLayout::kDataFirst;
  seen_ = kLayoutReports;
}

bool LayoutDetector::decided() const {
  return seen_ >= kLayoutReports && (possible_[0] != possible_[1]);
}

ReportLayout LayoutDetector::layout() const {
  return possible_[1] && !possible_[0] ? ReportLayout::kDataFirst : ReportLayout::kRecordFirst;
}

void encode_scan_report(std::span<const std::int16_t, kSamplesPerScanReport> s,
                        std::uint16_t scan_index, std::uint8_t record,
                        std::span<std::uint8_t, kScanReportBytes> r, ReportLayout l) {
  for (auto& b : r) b = 0;
  if (l == ReportLayout::kRecordFirst) r[0] = record;
  std::uint8_t* d = &r[data_at(l)];
  for (std::size_t i = 0, k = 0; i < 96; i += 3, k += 2) {
    const auto a = static_cast<unsigned>(s[k]) & 0xFFFU;
    const auto b = static_cast<unsigned>(s[k + 1]) & 0xFFFU;
    d[i] = static_cast<std::uint8_t>(a & 0xFF);
    d[i + 1] = static_cast<std::uint8_t>(((a >> 4) & 0xF0U) | ((b >> 8) & 0x0FU));
    d[i + 2] = static_cast<std::uint8_t>(b & 0xFF);
  }
  r[index_at(l)] = static_cast<std::uint8_t>(scan_index & 0xFF);
  r[index_at(l) + 1] = static_cast<std::uint8_t>(scan_index >> 8);
}

}  // namespace pof::daq::mcc
