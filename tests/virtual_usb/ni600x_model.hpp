#pragma once
// A virtual NI USB-6008/6009 speaking daq/include/pof/daq/protocol/ni_usb600x.hpp: it acknowledges commands on
// 0x81, runs a scan clock from the start command (10/03) and serves samples on 0x82 no earlier
// than its clock says they exist. Its analog inputs see the simulated knee (analog_bench.hpp):
// scan `index` of a session samples the bench's signal on the channels of the scan list, so the
// checker reads back from the same bench exactly what the device sent. It records every segment
// (start time, first index, rate) so that timestamps and the seam between segments can be measured.
#include <cstdint>
#include <limits>
#include <array>
#include <mutex>
#include <string>
#include <vector>

#include "analog_bench.hpp"
#include "pof/daq/protocol/ni_usb600x.hpp"
#include "usbdevfs_device.hpp"

namespace pof::vusb {

struct NiOptions {
  bool usb6009 = false;
  pof::daq::ni::ByteOrder order = pof::daq::ni::ByteOrder::kBig;
  double range_v = 10.0;
  double clock_ppm = 0.0;  // device crystal error: positive = fast
  bool silent = false;     // never answers a command ("a device that never answers")
  int short_every = 0;     // every Nth data URB is answered 2 bytes short (a valid short packet)
  // Variants where the public sources disagree (daq/include/pof/daq/protocol/ni_usb600x.hpp [3][9]):
  std::uint8_t reply_header = 0;  // header byte 1 of every reply: 00 ([C]) or 01 (6008 sources)
  bool padding_noise = false;     // padding bits below the value carry noise (no source checks them)
  double steady_volts = std::numeric_limits<double>::quiet_NaN();  // every input at this level
  int steady_noise_lsb = 1;  // +- this many LSB of noise on the steady level (0: none at all)
                                  // (+-1 LSB noise) instead of the simulated knee
  std::string serial;      // iSerialNumber string (descriptor index 3); empty = none
};

struct Segment {
  int session = 0;                // 1, 2, ... (a new one per start after a hello)
  std::int64_t first_index = 0;   // device scan index within the session
  std::uint32_t count = 0;
  std::int64_t start_us = 0;      // host time of scan first_index
  double rate_hz = 0;             // the device's real rate (with clock_ppm)
};

class Ni600xModel final : public DeviceModel {
 public:
  Ni600xModel(const NiOptions& o, AnalogBench& bench);

  void on_out(std::uint8_t ep, std::span<const std::uint8_t> data, std::int64_t now_us) override;
  InResult on_in(std::uint8_t ep, std::span<std::uint8_t> buf, std::int64_t now_us) override;
  void on_clear_halt(std::uint8_t ep) override;
  /// GET_DESCRIPTOR(string): language ids and the serial number.
  int on_control(const std::uint8_t* setup, std::span<std::uint8_t> data, std::int64_t now_us) override;

  /// The code the device sends for scan `index` of device session `session`, channel `ch` of the
  /// scan list (the bench's volts on that analog input, converted with the device's coding).
  [[nodiscard]] std::uint16_t code(int session, std::int64_t index, std::size_t ch);
  [[nodiscard]] unsigned bits() const { return coding_.bits; }

  // Scenario hooks (call with the device mutex held).
  void stop_scanning() { running_ = false; }   // stall/unplug: the scan stops
  /// odd: one 63-byte packet of 0xFF; else: one valid packet whose padding bits are set. Then
  /// the scan stops.
  void send_garbage(bool odd) { garbage_ = odd ? 1 : 2; }
  void power_cycle();

  // Results (device mutex held).
  std::vector<Segment> segments;
  std::vector<std::int64_t> seams_us;  // idle time between back-to-back segments
  int protocol_errors = 0;
  int requests_00 = 0;  // requests after the hello whose header byte 1 was 00
  int requests_01 = 0;  // ... was 01
  int hellos = 0;
  std::string last_command;  // name of the last command received (the stop sequence ends in 0D/00)
  std::size_t n_channels() const { return n_ch_; }

 private:
  NiOptions o_;
  AnalogBench& bench_;
  pof::daq::ni::SampleCoding coding_;
  std::array<unsigned, 8> ai_{0, 1, 2, 3, 4, 5, 6, 7};  // analog input of each scan-list entry [5]
  std::vector<std::vector<std::uint8_t>> replies_;
  std::size_t n_ch_ = 0;
  double rate_hz_ = 1000;  // nominal, from the clock divisor
  std::uint32_t count_ = 0;
  bool session_pending_ = false;
  int session_ = 0;
  std::int64_t index_ = 0;  // next device scan index in the session
  bool running_ = false;
  std::int64_t seg_start_us_ = 0;
  std::uint64_t sent_ = 0;
  std::int64_t prev_end_us_ = -1;
  long data_urbs_ = 0;
  int garbage_ = 0;
};

}  // namespace pof::vusb
