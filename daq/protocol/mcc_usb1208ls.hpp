#pragma once
// Measurement Computing USB-1208LS over HID (hidapi): reports, the AInScan timer and the sample
// decoders. Pure functions; the backend is daq/backends/usb1208ls.cpp.
//
//  1. Source (facts only, LGPL code not copied): wjasper/Linux_Drivers USB/mcc-libusb/
//     usb-1208LS.c, usb-1208LS.h, pmd.h; summary in ../shared/notes/daq-protocols.md. UNVERIFIED
//     on hardware by this project.
//  2. VID 0x09DB, PID 0x007A. Commands are 9-byte output reports {report id 0, cmd, args, pad}
//     (hid_write); replies are 8-byte input reports (hid_read_timeout, 1.5 s).
//  3. Commands: AIN 0x06 {ch, gain}, ALOAD_QUEUE 0x07 {count, (ch & 7) | gain | 0x80 ...}
//     (count 1, 2, 4 or 8; at most 6 entries per report), AIN_SCAN 0x0E {count lo, count hi,
//     timer preload, prescale, options}, AIN_STOP 0x10.
//  4. Gains: SE +-10 V = 0x08; differential +-20 V 0x00, 10 V 0x10, 5 V 0x20, 4 V 0x30,
//     2.5 V 0x40, 2 V 0x50, 1.25 V 0x60, 1 V 0x70.
//  5. AIn reply {lo, hi}: differential = 12-bit two's complement (hi << 8 | lo << 4) / 16;
//     single-ended = 11-bit offset (hi << 4 | lo & 0x0F) - 0x400. Volts: SE n * 10 / 0x3FF,
//     differential n * range / 0x7FF.
//  6. AInScan timer on a 6 MHz clock: prescale p by rate band (7: 100-199 Hz ... 1: 6000-8191 Hz,
//     setup time 0,0,0,1,3,6,10), timer = round(256 - 6e6 / (rate * 2^(p+1))), preload =
//     timer + setup. Options: 0x1 single execution, 0x2 burst, 0x4 block transfer, 0x8 trigger.
//  7. Scan data: 105-byte feature reports {record no, data[96], error, read addr[2], write
//     addr[2], scan index[2] (little-endian, from 1), extra}; every 3 data bytes hold two 12-bit
//     two's-complement samples: s0 = b0 | (b1 & 0xF0) << 4, s1 = b2 | (b1 & 0x0F) << 8.
//     64 samples per report.
//  8. OUR DESIGN: continuous acquisition = back-to-back AInScan bursts of `burst_samples`
//     (multiple of 64 and of the channel count), scan index carried over, as for the NI devices.
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
inline constexpr std::size_t kScanReportBytes = 105;    // [7]
inline constexpr std::size_t kSamplesPerScanReport = 64;
inline constexpr double kClockHz = 6e6;                 // [6]

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

/// [7] the 64 samples of a scan report, sign-extended 12-bit counts; returns the scan index.
std::uint16_t decode_scan_report(std::span<const std::uint8_t, kScanReportBytes> report,
                                 std::span<std::int16_t, kSamplesPerScanReport> samples);
/// Inverse of decode_scan_report (the virtual device and the tests).
void encode_scan_report(std::span<const std::int16_t, kSamplesPerScanReport> samples,
                        std::uint16_t scan_index, std::uint8_t record,
                        std::span<std::uint8_t, kScanReportBytes> report);
/// Volts of a 12-bit scan sample for a gain (scan data are two's complement for every gain).
double scan_counts_to_volts(std::int16_t counts, Gain gain);

}  // namespace pof::daq::mcc
