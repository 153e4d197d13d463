#pragma once
// NI USB-6008 / USB-6009 wire protocol: frames, the opcode table, the scan programme and the sample
// decoders. Pure functions, no libusb: the daemon backend (daq/src/backends/usb600x.cpp) and the virtual
// device of the tests (tests/virtual_usb/) both speak through this one module.
//
// What is known, where it comes from, and what is our own design (numbered so code can cite it):
//
//  1. Sources (public reverse engineering, UNVERIFIED on hardware; facts only, no code copied):
//     [C] seregioo/comedi comedi/drivers/ni_usb6009.c (captures of NI-DAQmx Base, 6009 0x3923:0x717b)
//     [P] argusro/datalogger-rpi datalogger/usb6008.py (pyusb, 6008 0x3923:0x717a)
//     [L] Linux drivers/comedi/drivers/ni_usb6501.c (USB-6501, same framing family)
//     [M] chrismerck/usb-6000 (raw frames of a USB-6008, 0x3923:0x717a)
//     Every fact with its sources, and where they disagree: docs/daq.md, "Protocol facts".
//  2. Transport: USB full speed, one interface, bulk endpoints with 64-byte packets: 0x01 OUT
//     commands, 0x81 IN replies, 0x82 IN sample data [C][P].
//  3. Frame: `00 HH | LEN BE16 | LEN-4 BE16 | 01 OP | 02 GRP | 00 00 | params`, LEN counts the
//     whole frame, padded to a multiple of 4 [C]. Hello is the one frame with 00 in the 02 byte [C].
//     The header byte HH is where the sources disagree: 00 in [C] (6009); 01 in [M] and [P]'s
//     docstring (6008) and "byte 1 is always 01" in [L] (6501).
//  4. Replies: generic ACK `00 HH 00 0C 00 08 01 00 00 00 00 02` [C]; hello answers 0x1C bytes and
//     channel setup (14/04) 0x18 bytes with the same first-12-byte shape (contents unknown; possibly
//     a memory read of calibration constants) [C]. A reply with either HH is accepted.
//     OUR DESIGN: hello goes out with HH = 00 (the one full scan programme published, [C]); every
//     later request repeats the HH of the hello's reply, so a device that speaks 00 01 is spoken
//     to as the 6008 sources do.
//  5. Parameter blocks start with a BE16 length that counts itself: the channel list (0F/02) is
//     `00 (2+2n)` + n BE16 channel numbers; the bank list (0E/02) is `00 (2+n)` + one bank byte per
//     channel, bank 02 for ai4-7 [C] (inference from the 8- and 4-channel captures).
//  6. Per-channel setup 14/04 `00 00 <code BE16> 00 08 00 00`: RSE code 0x30+8ch (ch0-3),
//     0x118+8(ch-4) (ch4-7), differential 0x50+8ch [C][notes]. Range 10/02
//     `00 00 <+lim mV BE32> <-lim mV BE32> FD FD 00 04 00 00 <pos> 00` [C] (`pos` is the position
//     in the scan list in our programme; the captures only show ai0-7 in order, where both agree).
//  7. Scan clock: 16/00 carries a BE32 divisor of a 24 MHz time base, 0x5DC0 = 1 kHz [C].
//  8. Finite scan: 0C/03, 0F/02, 0E/02, per channel 14/04 + 10/02, 0E/00 `01 00 00 00`, 16/00,
//     13/00, 15/00, 0F/00 scan count BE32, 12/03 total bytes BE32 (= scans x channels x 2), then
//     start 0F/03, 09/03, 09/00, 0A/00, 10/03; samples follow on 0x82, interleaved by channel in
//     scan-list order, no header [C]. Session init: 00/00 hello, 0B/00, 0C/00, 0D/00 [C][P].
//     Stop (seen in [P]): 0B/00, 0C/00, 0C/03, 0D/00.
//  9. Samples: 6009: big-endian 16-bit word, 14-bit value left-justified (>> 2) [C]. 6008: 12-bit
//     left-justified offset binary, 2048 = 0 V [P]; [P] reads the word little-endian, which
//     contradicts [C]'s family: the byte order is a configuration key (`sample_byte_order`,
//     default "auto": told from the data, ByteOrderDetector) and decoding is one tested function.
//     OUR DESIGN: 6009 codes are offset binary too (8192 = 0 V), volts = (code - mid) * range / mid.
//     Padding bits below the value: no source checks them ([C] ignores the low 2 bits, [P] the
//     low 4); a sample with them set is counted, never dropped.
// 10. OUR DESIGN, continuous acquisition (no public note shows it): back-to-back finite scans.
//     Each segment asks for as many scans as the BE32 byte count of 12/03 allows (>= 12 h at the
//     6009's 48 kS/s), the host re-arms with 0F/00..10/03 (no re-configuration) when the segment's
//     bytes have arrived, and the scan index is carried over. The seam (device idle between the
//     last scan of one segment and the first of the next) is measured in the virtual-device tests
//     and documented in docs/daq.md.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace pof::daq::ni {

inline constexpr std::uint8_t kEpCommandOut = 0x01;  // [2]
inline constexpr std::uint8_t kEpReplyIn = 0x81;     // [2]
inline constexpr std::uint8_t kEpDataIn = 0x82;      // [2]
inline constexpr std::size_t kMaxPacket = 64;        // [2] full-speed bulk
inline constexpr std::size_t kHeaderBytes = 12;      // [3]
inline constexpr double kTimebaseHz = 24e6;          // [7]

/// Every command the daemon sends, in one table (kOpcodes) with its opcode, group and source.
enum class Cmd : std::uint8_t {
  kHello,         // 00/00 [8]
  kSession0B,     // 0B/00 [8]
  kSession0C,     // 0C/00 [8]
  kSession0D,     // 0D/00 [8]
  kAiReset,       // 0C/03 [8]
  kChannelList,   // 0F/02 [5]
  kBankList,      // 0E/02 [5]
  kChannelSetup,  // 14/04 [6]
  kRange,         // 10/02 [6]
  kArm,           // 0E/00 [8]
  kClock,         // 16/00 [7]
  kCommit13,      // 13/00 [8]
  kCommit15,      // 15/00 [8]
  kScanCount,     // 0F/00 [8]
  kByteCount,     // 12/03 [8]
  kStart0F03,     // 0F/03 [8]
  kStart0903,     // 09/03 [8]
  kStart0900,     // 09/00 [8]
  kStart0A00,     // 0A/00 [8]
  kStart1003,     // 10/03 [8] last of the start sequence: sampling begins
  kCount
};

struct Opcode {
  Cmd cmd;
  std::uint8_t op;
  std::uint8_t group;
  std::size_t reply_bytes;  // [4]
  std::string_view name;
};

inline constexpr std::array<Opcode, static_cast<std::size_t>(Cmd::kCount)> kOpcodes{{
    {Cmd::kHello, 0x00, 0x00, 0x1C, "hello"},
    {Cmd::kSession0B, 0x0B, 0x00, 12, "session 0B"},
    {Cmd::kSession0C, 0x0C, 0x00, 12, "session 0C"},
    {Cmd::kSession0D, 0x0D, 0x00, 12, "session 0D"},
    {Cmd::kAiReset, 0x0C, 0x03, 12, "AI reset"},
    {Cmd::kChannelList, 0x0F, 0x02, 12, "channel list"},
    {Cmd::kBankList, 0x0E, 0x02, 12, "bank list"},
    {Cmd::kChannelSetup, 0x14, 0x04, 0x18, "channel setup"},
    {Cmd::kRange, 0x10, 0x02, 12, "range"},
    {Cmd::kArm, 0x0E, 0x00, 12, "arm"},
    {Cmd::kClock, 0x16, 0x00, 12, "scan clock"},
    {Cmd::kCommit13, 0x13, 0x00, 12, "commit 13"},
    {Cmd::kCommit15, 0x15, 0x00, 12, "commit 15"},
    {Cmd::kScanCount, 0x0F, 0x00, 12, "scan count"},
    {Cmd::kByteCount, 0x12, 0x03, 12, "byte count"},
    {Cmd::kStart0F03, 0x0F, 0x03, 12, "start 0F/03"},
    {Cmd::kStart0903, 0x09, 0x03, 12, "start 09/03"},
    {Cmd::kStart0900, 0x09, 0x00, 12, "start 09/00"},
    {Cmd::kStart0A00, 0x0A, 0x00, 12, "start 0A/00"},
    {Cmd::kStart1003, 0x10, 0x03, 12, "start 10/03"},
}};

constexpr const Opcode& opcode(Cmd c) { return kOpcodes[static_cast<std::size_t>(c)]; }

/// A frame on endpoint 0x01 or 0x81 (never longer than one packet).
struct Frame {
  std::array<std::uint8_t, kMaxPacket> bytes{};
  std::size_t size = 0;
  [[nodiscard]] std::span<const std::uint8_t> view() const { return {bytes.data(), size}; }
};

/// Builds the frame of `cmd` with `params` after the 12-byte header [3], header byte 1 = `hh`
/// (00 or 01 [3]). Throws std::length_error if the frame would not fit one packet (a programming
/// error: the scan programme is bounded).
Frame make_frame(Cmd cmd, std::span<const std::uint8_t> params = {}, std::uint8_t hh = 0);

/// A frame split into its parts (used by the virtual device and the tests).
struct ParsedFrame {
  std::uint8_t hh = 0;  // header byte 1 [3]
  std::uint8_t op = 0;
  std::uint8_t group = 0;
  std::span<const std::uint8_t> params;
};
/// nullopt when the bytes are not a well-formed frame [3] (length fields disagree, too short).
std::optional<ParsedFrame> parse_frame(std::span<const std::uint8_t> bytes);
/// The table entry for an opcode/group pair, or nullptr.
const Opcode* find_opcode(std::uint8_t op, std::uint8_t group);

/// The reply the device gives to `cmd` [4] (contents beyond the header are zero here).
Frame make_reply(Cmd cmd, std::uint8_t hh = 0);
/// The header byte 1 (00 or 01 [3]) when `reply` has the length and header the device gives to
/// `cmd` [4]; nullopt otherwise.
std::optional<std::uint8_t> reply_header(Cmd cmd, std::span<const std::uint8_t> reply);
inline bool reply_ok(Cmd cmd, std::span<const std::uint8_t> reply) {
  return reply_header(cmd, reply).has_value();
}

enum class Terminal { kRse, kDifferential };
enum class ByteOrder { kBig, kLittle };

/// Clock divisor [7] for a scan rate, and the rate the device will really run at.
std::uint32_t clock_divisor(double scan_rate_hz);
double rate_for_divisor(std::uint32_t divisor);

/// Per-channel setup code of 14/04 [6].
std::uint16_t channel_setup_code(std::uint8_t ai_channel, Terminal terminal);

struct ScanProgram {
  std::vector<std::uint8_t> channels;  // ai numbers in scan order
  Terminal terminal = Terminal::kRse;
  double range_v = 10.0;               // +- range
  std::uint32_t clock_divisor = 0x5DC0;
};

/// Session init after the hello [8]: 0B/00, 0C/00, 0D/00 (`hh`: header byte 1 [3][4]).
std::vector<Frame> session_frames(std::uint8_t hh = 0);
/// Configuration of a scan [5][6][7][8], from 0C/03 to 15/00.
std::vector<Frame> configure_frames(const ScanProgram& program, std::uint8_t hh = 0);
/// Arming and start of one finite segment of `scans` scans [8][10], 0F/00 to 10/03.
std::vector<Frame> start_frames(std::uint32_t scans, std::size_t n_channels, std::uint8_t hh = 0);
/// Stop sequence seen in [P] [8].
std::vector<Frame> stop_frames(std::uint8_t hh = 0);

/// Largest segment the 32-bit byte count of 12/03 allows [10].
std::uint32_t max_segment_scans(std::size_t n_channels);

// --- Samples [9] --------------------------------------------------------------------------------
struct SampleCoding {
  unsigned bits;    // significant bits: 12 (6008), 14 (6009)
  ByteOrder order;  // of the 16-bit word on the wire
};
constexpr SampleCoding usb6008_coding(ByteOrder order) { return {12, order}; }
constexpr SampleCoding usb6009_coding() { return {14, ByteOrder::kBig}; }

struct Sample {
  std::uint16_t code;  // offset binary, `bits` wide
  bool padding_set;    // a bit below the value was set (counted, not an error [9])
};
/// USB-6008: 12-bit left-justified offset binary in a 16-bit word of the given byte order.
Sample decode_usb6008_sample(const std::uint8_t* word, ByteOrder order);
/// USB-6009: 14-bit left-justified in a big-endian word.
Sample decode_usb6009_sample(const std::uint8_t* word);
/// Either of the above by coding.
Sample decode_sample(const std::uint8_t* word, SampleCoding coding);
/// Inverse of decode_sample (virtual device, tests).
void encode_sample(std::uint16_t code, SampleCoding coding, std::uint8_t* word);

/// Offset-binary code to volts for a +-range_v input, and back (clamped to the code range).
double code_to_volts(std::uint16_t code, unsigned bits, double range_v);
std::uint16_t volts_to_code(double volts, unsigned bits, double range_v);
/// [9] Tells the USB-6008's sample byte order from the data, window by window: read both ways,
/// the right order is the one whose signal is far smoother (a byte swap moves the low bits of the
/// value, where the noise is, to the top: one LSB of noise becomes 256 codes). A window without
/// noise or motion tells nothing and leaves the verdict as it was; the first verdict needs one
/// telling window, and later windows re-check it while streaming.
class ByteOrderDetector {
 public:
  static constexpr std::size_t kWindowScans = 256;
  static constexpr std::size_t kMaxChannels = 8;
  ByteOrderDetector(unsigned bits, std::size_t n_channels);
  /// Feeds `n_scans` scans of raw 16-bit words, channel-interleaved. Returns true when the verdict
  /// changed (first decision or a reversal).
  bool feed(const std::uint8_t* words, std::size_t n_scans);
  [[nodiscard]] bool decided() const { return decided_; }
  /// The decided order; big-endian (the 6009's, [C]) while undecided.
  [[nodiscard]] ByteOrder order() const { return order_; }
  /// Reversals after the first decision (the data contradicted the verdict).
  [[nodiscard]] int reversals() const { return reversals_; }

 private:
  unsigned bits_;
  std::size_t n_ch_;
  std::array<std::array<std::uint16_t, kMaxChannels>, 2> prev_{};
  bool have_prev_ = false;
  std::array<std::uint64_t, 2> variation_{};
  std::size_t scans_ = 0;
  bool decided_ = false;
  ByteOrder order_ = ByteOrder::kBig;
  int reversals_ = 0;
};

/// One LSB in volts.
constexpr double lsb_volts(unsigned bits, double range_v) {
  return 2.0 * range_v / static_cast<double>(1U << bits);
}

}  // namespace pof::daq::ni
