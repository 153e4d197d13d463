// NI USB-6008/6009 protocol: see the numbered block comment in ni_usb600x.hpp.
#include "protocol/ni_usb600x.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace pof::daq::ni {
namespace {

void put_be16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v >> 8);
  p[1] = static_cast<std::uint8_t>(v & 0xFF);
}
void put_be32(std::uint8_t* p, std::uint32_t v) {
  p[0] = static_cast<std::uint8_t>(v >> 24);
  p[1] = static_cast<std::uint8_t>((v >> 16) & 0xFF);
  p[2] = static_cast<std::uint8_t>((v >> 8) & 0xFF);
  p[3] = static_cast<std::uint8_t>(v & 0xFF);
}
std::uint16_t get_be16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

}  // namespace

Frame make_frame(Cmd cmd, std::span<const std::uint8_t> params) {
  const Opcode& oc = opcode(cmd);
  std::size_t len = kHeaderBytes + params.size();
  len = (len + 3U) & ~std::size_t{3};  // [3] padded to 4 bytes
  if (len > kMaxPacket) throw std::length_error("NI frame longer than one 64-byte packet");
  Frame f;
  f.size = len;
  put_be16(&f.bytes[2], static_cast<std::uint16_t>(len));
  put_be16(&f.bytes[4], static_cast<std::uint16_t>(len - 4));
  f.bytes[6] = 0x01;
  f.bytes[7] = oc.op;
  f.bytes[8] = cmd == Cmd::kHello ? 0x00 : 0x02;  // [3] hello has 00 here
  f.bytes[9] = oc.group;
  std::copy(params.begin(), params.end(), f.bytes.begin() + kHeaderBytes);
  return f;
}

std::optional<ParsedFrame> parse_frame(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kHeaderBytes) return std::nullopt;
  const std::uint16_t len = get_be16(&bytes[2]);
  if (bytes[0] != 0 || bytes[1] != 0 || len != bytes.size() || get_be16(&bytes[4]) != len - 4 ||
      bytes[6] != 0x01) {
    return std::nullopt;
  }
  ParsedFrame p;
  p.op = bytes[7];
  p.group = bytes[9];
  p.params = bytes.subspan(kHeaderBytes);
  return p;
}

const Opcode* find_opcode(std::uint8_t op, std::uint8_t group) {
  for (const auto& oc : kOpcodes) {
    if (oc.op == op && oc.group == group) return &oc;
  }
  return nullptr;
}

Frame make_reply(Cmd cmd) {
  const std::size_t len = opcode(cmd).reply_bytes;
  Frame f;
  f.size = len;
  put_be16(&f.bytes[2], static_cast<std::uint16_t>(len));
  put_be16(&f.bytes[4], static_cast<std::uint16_t>(len - 4));
  f.bytes[6] = 0x01;
  f.bytes[11] = 0x02;  // [4]
  return f;
}

bool reply_ok(Cmd cmd, std::span<const std::uint8_t> reply) {
  const Frame want = make_reply(cmd);
  if (reply.size() != want.size) return false;
  return std::equal(want.bytes.begin(), want.bytes.begin() + kHeaderBytes, reply.begin());
}

std::uint32_t clock_divisor(double scan_rate_hz) {
  const double d = std::round(kTimebaseHz / scan_rate_hz);
  return static_cast<std::uint32_t>(std::clamp(d, 1.0, 4294967295.0));
}

double rate_for_divisor(std::uint32_t divisor) { return kTimebaseHz / divisor; }

std::uint16_t channel_setup_code(std::uint8_t ch, Terminal terminal) {
  if (terminal == Terminal::kDifferential) return static_cast<std::uint16_t>(0x50 + 8 * ch);
  if (ch < 4) return static_cast<std::uint16_t>(0x30 + 8 * ch);
  return static_cast<std::uint16_t>(0x118 + 8 * (ch - 4));
}

std::vector<Frame> session_frames() {
  return {make_frame(Cmd::kHello), make_frame(Cmd::kSession0B), make_frame(Cmd::kSession0C),
          make_frame(Cmd::kSession0D)};
}

std::vector<Frame> configure_frames(const ScanProgram& prog) {
  std::vector<Frame> out;
  const std::size_t n = prog.channels.size();
  if (n == 0 || n > 8) throw std::invalid_argument("NI scan programme: 1 to 8 channels");
  out.push_back(make_frame(Cmd::kAiReset));
  {  // [5] channel list
    std::array<std::uint8_t, 2 + 2 * 8> p{};
    put_be16(&p[0], static_cast<std::uint16_t>(2 + 2 * n));
    for (std::size_t i = 0; i < n; ++i) put_be16(&p[2 + 2 * i], prog.channels[i]);
    out.push_back(make_frame(Cmd::kChannelList, std::span(p).first(2 + 2 * n)));
  }
  {  // [5] bank list
    std::array<std::uint8_t, 2 + 8> p{};
    put_be16(&p[0], static_cast<std::uint16_t>(2 + n));
    for (std::size_t i = 0; i < n; ++i) {
      p[2 + i] = prog.terminal == Terminal::kRse && prog.channels[i] >= 4 ? 0x02 : 0x00;
    }
    out.push_back(make_frame(Cmd::kBankList, std::span(p).first(2 + n)));
  }
  const auto lim_mv = static_cast<std::int32_t>(std::lround(prog.range_v * 1000.0));
  for (std::size_t i = 0; i < n; ++i) {  // [6]
    std::array<std::uint8_t, 8> setup{};
    put_be16(&setup[2], channel_setup_code(prog.channels[i], prog.terminal));
    setup[5] = 0x08;
    out.push_back(make_frame(Cmd::kChannelSetup, setup));
    std::array<std::uint8_t, 16> range{};
    put_be32(&range[0], static_cast<std::uint32_t>(lim_mv));
    put_be32(&range[4], static_cast<std::uint32_t>(-lim_mv));
    range[8] = 0xFD;
    range[9] = 0xFD;
    range[11] = 0x04;
    range[14] = static_cast<std::uint8_t>(i);
    out.push_back(make_frame(Cmd::kRange, range));
  }
  const std::array<std::uint8_t, 4> arm{0x01, 0, 0, 0};
  out.push_back(make_frame(Cmd::kArm, arm));
  std::array<std::uint8_t, 4> clk{};
  put_be32(&clk[0], prog.clock_divisor);
  out.push_back(make_frame(Cmd::kClock, clk));
  out.push_back(make_frame(Cmd::kCommit13));
  out.push_back(make_frame(Cmd::kCommit15));
  return out;
}

std::vector<Frame> start_frames(std::uint32_t scans, std::size_t n_channels) {
  std::array<std::uint8_t, 4> count{};
  put_be32(&count[0], scans);
  std::array<std::uint8_t, 4> bytes{};
  put_be32(&bytes[0], static_cast<std::uint32_t>(std::uint64_t{scans} * n_channels * 2));
  return {make_frame(Cmd::kScanCount, count), make_frame(Cmd::kByteCount, bytes),
          make_frame(Cmd::kStart0F03),         make_frame(Cmd::kStart0903),
          make_frame(Cmd::kStart0900),         make_frame(Cmd::kStart0A00),
          make_frame(Cmd::kStart1003)};
}

std::vector<Frame> stop_frames() {
  return {make_frame(Cmd::kSession0B), make_frame(Cmd::kSession0C), make_frame(Cmd::kAiReset),
          make_frame(Cmd::kSession0D)};
}

std::uint32_t max_segment_scans(std::size_t n_channels) {
  return static_cast<std::uint32_t>(std::numeric_limits<std::uint32_t>::max() / (2 * n_channels));
}

std::optional<std::uint16_t> decode_sample(const std::uint8_t* word, SampleCoding coding) {
  const auto w = static_cast<std::uint16_t>(coding.order == ByteOrder::kBig
                                                ? (word[0] << 8) | word[1]
                                                : (word[1] << 8) | word[0]);
  const unsigned shift = 16U - coding.bits;
  if ((w & ((1U << shift) - 1U)) != 0U) return std::nullopt;  // [9] padding must be zero
  return static_cast<std::uint16_t>(w >> shift);
}

std::optional<std::uint16_t> decode_usb6008_sample(const std::uint8_t* word, ByteOrder order) {
  return decode_sample(word, usb6008_coding(order));
}

std::optional<std::uint16_t> decode_usb6009_sample(const std::uint8_t* word) {
  return decode_sample(word, usb6009_coding());
}

void encode_sample(std::uint16_t code, SampleCoding coding, std::uint8_t* word) {
  const auto w = static_cast<std::uint16_t>(code << (16U - coding.bits));
  const auto hi = static_cast<std::uint8_t>(w >> 8);
  const auto lo = static_cast<std::uint8_t>(w & 0xFF);
  word[0] = coding.order == ByteOrder::kBig ? hi : lo;
  word[1] = coding.order == ByteOrder::kBig ? lo : hi;
}

double code_to_volts(std::uint16_t code, unsigned bits, double range_v) {
  const double mid = static_cast<double>(1U << (bits - 1));
  return (static_cast<double>(code) - mid) * range_v / mid;
}

std::uint16_t volts_to_code(double volts, unsigned bits, double range_v) {
  const double mid = static_cast<double>(1U << (bits - 1));
  const double c = std::round(volts / range_v * mid + mid);
  return static_cast<std::uint16_t>(std::clamp(c, 0.0, 2.0 * mid - 1.0));
}

}  // namespace pof::daq::ni
