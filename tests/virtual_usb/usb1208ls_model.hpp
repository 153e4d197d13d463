#pragma once
// A virtual MCC USB-1208LS as hidapi's libusb flavour sees it (usbdevfs, through the same
// UsbdevfsDevice), on the device's published descriptors (docs/virtual-usb.md, "The USB-1208LS on
// the bus"): low speed, an 8-byte EP0, one HID interface with interrupt IN 0x81 and interrupt OUT
// 0x01 of 8 bytes each, bInterval 10 ms. Commands arrive on 0x01 (hidapi writes output reports
// there when the interface has an OUT endpoint), replies leave on 0x81 from the frame after the
// command, scan data are 105-byte feature reports (GET_REPORT on EP0) paced by the device's scan
// timer. Protocol: daq/include/pof/daq/protocol/mcc_usb1208ls.hpp. Its analog inputs see the
// simulated knee (analog_bench.hpp); a session starts at each channel-queue load.
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "analog_bench.hpp"
#include "pof/daq/protocol/mcc_usb1208ls.hpp"
#include "usbdevfs_device.hpp"

namespace pof::vusb {

/// How the virtual device answers where the public sources leave it open (mcc_usb1208ls.hpp [7]).
struct MccOptions {
  pof::daq::mcc::ReportLayout layout = pof::daq::mcc::ReportLayout::kRecordFirst;
  std::size_t report_bytes = pof::daq::mcc::kScanReportBytes;  // 105, or 104 (data-first only)
  bool se_scan_offset = false;   // single-ended scan samples offset-coded like the AIn reply
  bool refuse_feature = false;   // every feature GET_REPORT stalls (hidapi returns -1)
};

class Usb1208lsModel final : public DeviceModel {
 public:
  // Interface 0 (HID, 2 endpoints), HID class descriptor, interrupt IN 0x81 and interrupt OUT 0x01,
  // wMaxPacketSize 8, bInterval 10 (the published listing: docs/virtual-usb.md).
  static constexpr const char* kInterfaceHex =
      "090400000203000000" "092110010001221c00" "0705810308000a" "0705010308000a";
  static constexpr int kInterfaceLen = 32;
  static constexpr std::uint16_t kBcdUsb = 0x0110;
  static constexpr int kMaxPacket0 = 8;
  static constexpr const char* kSpeed = "1.5";
  /// The device's firmware answers a command from the frame after it arrived (our assumption:
  /// no public source times it; the bus polls dominate).
  static constexpr std::int64_t kReplyLatencyUs = 1000;

  /// `layout`: where the device puts data and scan index in a feature report: the public sources
  /// disagree (daq/include/pof/daq/protocol/mcc_usb1208ls.hpp [7]).
  Usb1208lsModel(double clock_ppm, AnalogBench& bench, MccOptions o = {})
      : ppm_(clock_ppm), bench_(bench), layout_(o.layout), opt_(o) {}

  void on_out(std::uint8_t ep, std::span<const std::uint8_t> data, std::int64_t now_us) override;
  InResult on_in(std::uint8_t ep, std::span<std::uint8_t> buf, std::int64_t now_us) override;
  int on_control(const std::uint8_t* setup, std::span<std::uint8_t> data, std::int64_t now_us) override;

  /// The volts of scan `idx`, channel `ch` (of the queue) of session `session` as the device
  /// digitised them; `idx` is the bench scan (bench_scan_of).
  [[nodiscard]] double volts_sent(int session, std::int64_t idx, std::size_t ch);
  /// The seam between two executions of a session: the device idle, the bench went on.
  struct Seam {
    int session;
    std::int64_t scans_before;  // scans the session's executions delivered before it
    std::int64_t skipped;       // scans the device did not take
  };
  std::vector<Seam> seams;
  /// The bench scan of the `delivered`-th scan the session's executions delivered.
  [[nodiscard]] std::int64_t bench_scan_of(int session, std::int64_t delivered) const;
  /// Sessions whose data came from AInScans (else from single AIn reads).
  std::vector<int> scan_sessions;
  [[nodiscard]] bool scanned(int session) const;
  int feature_refusals = 0;
  /// Single AIn reads: the volts of read `idx` of channel `ch` (11-bit single-ended coding); the
  /// k-th read of every channel samples bench scan k of the session.
  [[nodiscard]] double volts_single(int session, std::int64_t idx, std::size_t ch);
  bool single_reads_seen = false;
  void power_cycle();

  int sessions = 0;
  int protocol_errors = 0;  // commands the device refuses (a queue of 3, 5, 6 or 7 entries [3])
  int bursts = 0;
  double rate_hz = 0;  // aggregate sample rate of the last AInScan

 private:
  [[nodiscard]] std::int16_t counts(int session, std::int64_t sample);
  void command(std::span<const std::uint8_t> r, std::int64_t now_us);

  double ppm_;
  AnalogBench& bench_;
  pof::daq::mcc::ReportLayout layout_;
  MccOptions opt_;
  double end_us_ = -1;                // when the session's last execution took its last sample
  std::int64_t delivered_ = 0;        // scans the session's executions delivered so far
  void begin_session();
  std::vector<std::uint8_t> channels_;
  pof::daq::mcc::Gain gain_ = pof::daq::mcc::kSe10V;
  bool queue_loaded_ = false;
  bool running_ = false;
  std::int64_t start_us_ = 0;
  std::uint16_t count_ = 0;
  std::uint16_t last_index_ = 0;   // scan index of the last report handed out
  std::int64_t session_sample_ = 0;  // first sample of the current burst within the session
  std::vector<std::uint8_t> last_report_ = std::vector<std::uint8_t>(pof::daq::mcc::kScanReportBytes, 0);
  struct Reply {
    std::int64_t ready_us;
    std::vector<std::uint8_t> bytes;
  };
  std::deque<Reply> replies_;
  std::vector<std::int64_t> reads_ = std::vector<std::int64_t>(8, 0);  // AIn reads per channel
  [[nodiscard]] std::int16_t se_counts(int session, std::int64_t idx, std::size_t ch);
};

}  // namespace pof::vusb
