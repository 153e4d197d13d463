#pragma once
// Measurement Computing USB-1208LS over HID (hidapi): reports, the AInScan timer and the sample
// decoders. Pure functions; the backend is daq/src/backends/usb1208ls.cpp.
//
//  1. Sources (facts only, LGPL code not copied), UNVERIFIED on hardware by this project; every
//     fact with its source and where they disagree: docs/daq.md, "Protocol facts".
//     [W]  wjasper/Linux_Drivers USB/mcc-libusb/usb-1208LS.c, usb-1208LS.h, pmd.c
//     [WP] wjasper/Linux_Drivers USB/python/usb_1208LS.py
//     [RD] ryan-duve/MCCDAQ-1208LS-backend usb-1208LS.c (older libhid copy)
//     [M]  MCC USB-1208LS user manual, p. 9 (specifications)
//  2. VID 0x09DB, PID 0x007A. Commands are 9-byte output reports {report id 0, cmd, args, pad}
//     (hid_write); replies are 8-byte input reports (hid_read_timeout, 1.5 s).
//  3. Commands: AIN 0x06 {ch, gain}, ALOAD_QUEUE 0x07 {count, (ch & 7) | gain | 0x80 ...}
//     (count 1, 2, 4 or 8 only: [W] comment "can be 1, 2, 4, or 8", [WP] ALoadQueue refuses
//     other counts; at most 6 entries per report), AIN_SCAN 0x0E {count lo, count hi,
//     timer preload, prescale, options}, AIN_STOP 0x10.
//  4. Gains: SE +-10 V = 0x08; differential +-20 V 0x00, 10 V 0x10, 5 V 0x20, 4 V 0x30,
//     2.5 V 0x40, 2 V 0x50, 1.25 V 0x60, 1 V 0x70.
//  5. AIn reply {lo, hi}: differential = 12-bit two's complement (hi << 8 | lo << 4) / 16;
//     single-ended = 11-bit offset (hi << 4 | lo & 0x0F) - 0x400. Volts ([W] volts_LS, used for
//     AIn replies and scan samples alike): SE n * 10 / 0x3FF, differential n * range / 0x7FF.
//  6. AInScan timer on a 6 MHz clock: prescale p by rate band (7: 100-199 Hz ... 1: 6000-8191 Hz,
//     setup time 0,0,0,1,3,6,10), timer = round(256 - 6e6 / (rate * 2^(p+1))), preload =
//     timer + setup. Options: 0x1 single execution, 0x2 burst, 0x4 block transfer, 0x8 trigger.
//  7. Scan data: 105-byte feature reports, 64 samples each; every 3 data bytes hold two 12-bit
//     two's-complement samples: s0 = b0 | (b1 & 0xF0) << 4, s1 = b2 | (b1 & 0x0F) << 8; scan
//     index little-endian, from 1. The sources disagree on where the data start (ReportLayout):
//     [W] {record no, data[96], error, read addr[2], write addr[2], scan index[2], extra}: index
//     at bytes 102-103; [WP] and [RD]: data from byte 0, index at 101-102. The backend detects
//     the layout from which index field counts 1, 2, 3 ... (detect_layout below).
//     [WP] asks hidapi for 105 bytes including the report id, i.e. 104 on the wire, and unpacks
//     them as [W]'s struct without the record number: {data[96], error, read addr[2], write
//     addr[2], scan index[2], extra} = 104 bytes. A device may therefore answer the GET_REPORT
//     with 104 or 105 bytes; the length decides (layout_for_size): 104 can only be data-first,
//     105 is either and is detected from the scan index as above.
//     Single-ended scan samples: no public source ran a single-ended AInScan ([W] test program and
//     [WP] scan only differential gains), while the single-ended AIn reply is 11-bit offset
//     coded [5]. The coding is decided per session from evidence (se_scan_coding_from): an AIn
//     reading of the first queued channel against the first scan sample of that channel read
//     both ways; the two codings differ by 0x400 counts (10 V), so the verdict is unambiguous
//     unless the input moved by more than 2.5 V between the two readings (tolerance 0x100).
//  8. Rates [M]: continuous scanning at most 1.2 kS/s aggregate; burst mode (options 0x2, the
//     device signals the end of a block with an input report holding 0xA5 [W][WP]) at most 8 kS/s
//     but at most 4096 samples (its FIFO); software-paced (one AIn per sample) about 50 S/s.
//  9. OUR DESIGN: continuous acquisition = back-to-back single-execution, non-burst AInScans as
//     long as the 16-bit count allows (65 s at 1 kS/s; whole reports and queue cycles,
//     acquisition.segment_scans shortens them), aggregate rate limited to [8]'s 1.2 kS/s. The
//     device is idle between the last sample of one execution and the start of the next (the
//     seam: the read of the last report plus the AInScan command, 17-28 ms at low speed, the
//     report asked for when the device's timer completes it, docs/daq.md fact 18): every seam is
//     published as lost scans (FLAG_GAP, dropped_scans = its length from the host clock), never
//     hidden behind a continuous index. Continuous execution (options bit 0 clear, [WP] docstring
//     "count is equal to packet size (64)") is not used: no public program runs it, so how its
//     scan index wraps and what an overrun looks like is unknown.
//     A device that refuses the feature report (hid_get_feature_report -1 under hidapi-libusb
//     while AIn works: a public user report against [W], confirmed by its author) cannot scan;
//     with acquisition.mcc_mode = "auto" the backend then reads single AIns, host-paced at
//     kFallbackReadsHz / channels scans/s, and says so. Burst mode is not used (a 4096-sample
//     block then a pause is not a stream). A channel list of 3, 5, 6 or 7 is padded to the next
//     allowed queue length with unused inputs whose samples are dropped (queue_length).
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

namespace pof::daq::mcc {

inline constexpr std::uint16_t kVendorId = 0x09DB;
inline constexpr std::uint16_t kProductId = 0x007A;
inline constexpr std::size_t kOutReportBytes = 9;       // [2] with report id 0
inline constexpr std::size_t kInReportBytes = 8;        // [2]
inline constexpr std::size_t kScanReportBytes = 105;    // [7] the longer reading
inline constexpr std::size_t kScanReportBytesNoRecord = 104;  // [7] [WP]: no record number
inline constexpr std::uint16_t kMaxScanCount = 65535;   // [3] 16-bit count (lo, hi bytes)
inline constexpr std::size_t kSamplesPerScanReport = 64;
inline constexpr double kClockHz = 6e6;                 // [6]
inline constexpr double kMinTimerRateHz = 100.0;        // [6] aggregate
inline constexpr double kMaxContinuousRateHz = 1200.0;  // [8] aggregate, continuous scan
inline constexpr double kMaxSoftwarePacedHz = 50.0;     // [8] AIn reads per second
// The software-paced fallback's rate [9]: an AIn is an interrupt OUT then an interrupt IN, each
// moved at most once per 10 ms (docs/daq.md fact 18), 20 ms back to back: 50 reads/s is the bus's
// own limit and leaves the host no slack. 90 % of it.
inline constexpr double kFallbackReadsHz = 45.0;
inline constexpr std::uint8_t kEndOfBlockFlag = 0xA5;   // [8] burst mode (not used, see [9])

/// [3][9] the queue length the device accepts for `n` channels: 1, 2, 4 or 8 (0 above 8).
std::size_t queue_length(std::size_t n);

enum Command : std::uint8_t {  // [3]
  kAIn = 0x06,
  kALoadQueue = 0x07,
  kAInScan = 0x0E,
  kAInStop = 0x10,
};

enum Gain : std::uint8_t {  // [4]
  kSe10V = 0x08,
  kBp20V = 0x00,
  kBp10V = 0x10,
  kBp5V = 0x20,
  kBp4V = 0x30,
  kBp2_5V = 0x40,
  kBp2V = 0x50,
  kBp1_25V = 0x60,
  kBp1V = 0x70,
};

/// The gain code for a terminal mode and +-range; nullopt when the device has no such range.
std::optional<Gain> gain_for(bool differential, double range_v);
/// Full-scale volts of a gain code.
double gain_range_v(Gain g);

using OutReport = std::array<std::uint8_t, kOutReportBytes>;

OutReport ain_report(std::uint8_t channel, Gain gain);
/// Channel/gain queue: one report per <= 6 entries [3]; returns how many reports were filled.
/// Throws std::invalid_argument unless 1 to 8 channels are given (the queue's size [3]).
std::size_t load_queue_reports(std::span<const std::uint8_t> channels, Gain gain,
                               std::array<OutReport, 2>& out);
OutReport ain_stop_report();

struct ScanTimer {
  std::uint8_t prescale;
  std::uint8_t preload;
  double actual_rate_hz;  // the rate the timer really gives (before the setup-time offset)
};
/// [6]; nullopt outside 100-8191 Hz.
std::optional<ScanTimer> scan_timer(double rate_hz);
OutReport ain_scan_report(std::uint16_t count, const ScanTimer& t, std::uint8_t options);

/// [5] single AIn replies, as signed counts.
std::int16_t decode_ain_differential(std::uint8_t lo, std::uint8_t hi);
std::int16_t decode_ain_single_ended(std::uint8_t lo, std::uint8_t hi);
double counts_to_volts(std::int16_t counts, Gain gain);

/// [7] where the samples and the scan index sit in a feature report.
enum class ReportLayout : std::uint8_t {
  kRecordFirst,  // [W]: record no. at 0, data 1-96, scan index 102-103
  kDataFirst,    // [WP], [RD]: data 0-95, scan index 101-102
};
const char* layout_name(ReportLayout l);
/// [7] the layout a report of `wire_bytes` can only have: 104 -> data-first; nullopt for 105
/// (either: detect it from the scan index) and for any other length (not a scan report).
std::optional<ReportLayout> layout_for_size(std::size_t wire_bytes);
/// [7] whether `wire_bytes` is the length of a scan report (104 or 105).
bool is_scan_report_size(std::size_t wire_bytes);

/// [7] how single-ended scan samples are coded in their 12-bit field.
enum class SeScanCoding : std::uint8_t {
  kTwosComplement,  // as differential scan samples ([W] decode_scan_report)
  kOffset,          // as the single-ended AIn reply: field - 0x400
};
/// The signed count of a 12-bit scan field under a coding.
std::int16_t se_scan_counts(unsigned field12, SeScanCoding c);
/// [7] the 12-bit field of a decoded (sign-extended) scan sample.
unsigned scan_field12(std::int16_t decoded);
/// [7] the coding under which scan sample field `field12` agrees with an AIn reading of the same
/// input (`ain_counts`, decode_ain_single_ended) within `tolerance` counts while the other one
/// does not; nullopt when neither or both agree (no evidence).
std::optional<SeScanCoding> se_scan_coding_from(std::int16_t ain_counts, unsigned field12,
                                                int tolerance = 0x100);

using ScanReport = std::span<const std::uint8_t, kScanReportBytes>;
/// [7] the scan index of a report read with layout `l`.
std::uint16_t scan_index(ScanReport report, ReportLayout l);
/// [7] the 64 samples of a scan report, sign-extended 12-bit counts; returns the scan index.
std::uint16_t decode_scan_report(ScanReport report, std::span<std::int16_t, kSamplesPerScanReport> samples,
                                 ReportLayout l = ReportLayout::kRecordFirst);
/// Inverse of decode_scan_report (the virtual device and the tests).
void encode_scan_report(std::span<const std::int16_t, kSamplesPerScanReport> samples,
                        std::uint16_t scan_index, std::uint8_t record,
                        std::span<std::uint8_t, kScanReportBytes> report,
                        ReportLayout l = ReportLayout::kRecordFirst);

/// [7] layout detection from the scan index's consistency. Feed every report that either layout
/// may read as the next one (`expect`, from 1 in each scan); `decided()` once exactly one layout
/// has counted `kLayoutReports` reports in a row while the other has not.
class LayoutDetector {
 public:
  static constexpr int kLayoutReports = 2;
  /// True when `report` is the next one under a layout still possible (i.e. not a repeat).
  bool is_next(ScanReport report, std::uint16_t expect) const;
  /// Records a report accepted by is_next().
  void accept(ScanReport report, std::uint16_t expect);
  /// The layout is known from elsewhere (the report's length: layout_for_size).
  void force(ReportLayout l);
  [[nodiscard]] bool decided() const;
  [[nodiscard]] ReportLayout layout() const;

 private:
  bool possible_[2] = {true, true};
  int seen_ = 0;
};

/// [5] volts of a count for a gain ([W] volts_LS): SE x 10 / 0x3FF, differential x range / 0x7FF.
/// Scan samples (12-bit two's complement for every gain [7]) use the same factors.
double scan_counts_to_volts(std::int16_t counts, Gain gain);
/// The largest magnitude a scan count reaches for a gain (full scale): 0x3FF SE, 0x7FF else.
int full_scale_counts(Gain gain);

}  // namespace pof::daq::mcc
