// NI USB-6008/6009 protocol: see the numbered block comment in ni_usb600x.hpp.
#include "pof/daq/protocol/ni_usb600x.hpp"

#include <algorithm>
#include <cstdlib>
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

// The 8 header bytes every frame shares [3]: 00 hh, total length, length - 4, 01 (the opcode
// follows at byte 7).
Frame frame_with_header(std::size_t len, std::uint8_t hh) {
  Frame f;
  f.size = len;
  f.bytes[1] = hh;
  put_be16(&f.bytes[2], static_cast<std::uint16_t>(len));
  put_be16(&f.bytes[4], static_cast<std::uint16_t>(len - 4));
  f.bytes[6] = 0x01;
  return f;
}

}  // namespace

Frame make_frame(Cmd cmd, std::span<const std::uint8_t> params, std::uint8_t hh) {
  const Opcode& oc = opcode(cmd);
  std::size_t len = kHeaderBytes + params.size();
  len = (len + 3U) & ~std::size_t{3};  // [3] padded to 4 bytes
  if (len > kMaxPacket) throw std::length_error("NI frame longer than one 64-byte packet");
  Frame f = frame_with_header(len, hh);
  f.bytes[7] = oc.op;
  f.bytes[8] = cmd == Cmd::kHello ? 0x00 : 0x02;  // [3] hello has 00 here
  f.bytes[9] = oc.group;
  std::copy(params.begin(), params.end(), f.bytes.begin() + kHeaderBytes);
  return f;
}

std::optional<ParsedFrame> parse_frame(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kHeaderBytes) return std::nullopt;
  const std::uint16_t len = get_be16(&bytes[2]);
  if (bytes[0] != 0 || bytes[1] > 1 || len != bytes.size() || get_be16(&bytes[4]) != len - 4 ||
      bytes[6] != 0x01) {
    return std::nullopt;
  }
  ParsedFrame p;
  p.hh = bytes[1];
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

Frame make_reply(Cmd cmd, std::uint8_t hh) {
  Frame f = frame_with_header(opcode(cmd).reply_bytes, hh);
  f.bytes[11] = 0x02;  // [4]
  return f;
}

std::optional<std::uint8_t> reply_header(Cmd cmd, std::span<const std::uint8_t> reply) {
  if (reply.size() < 2 || reply[1] > 1) return std::nullopt;  // [3] 00 00 or 00 01
  const Frame want = make_reply(cmd, reply[1]);
  if (reply.size() != want.size ||
      !std::equal(want.bytes.begin(), want.bytes.begin() + kHeaderBytes, reply.begin())) {
    return std::nullopt;
  }
  return reply[1];
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

std::vector<Frame> session_frames(std::uint8_t hh) {
  return {make_frame(Cmd::kSession0B, {}, hh), make_frame(Cmd::kSession0C, {}, hh),
          make_frame(Cmd::kSession0D, {}, hh)};
}

std::vector<Frame> configure_frames(const ScanProgram& prog, std::uint8_t hh) {
  std::vector<Frame> out;
  const std::size_t n = prog.channels.size();
  if (n == 0 || n > 8) throw std::invalid_argument("NI scan programme: 1 to 8 channels");
  out.push_back(make_frame(Cmd::kAiReset, {}, hh));
  {  // [5] channel list
    std::array<std::uint8_t, 2 + 2 * 8> p{};
    put_be16(&p[0], static_cast<std::uint16_t>(2 + 2 * n));
    for (std::size_t i = 0; i < n; ++i) put_be16(&p[2 + 2 * i], prog.channels[i]);
    out.push_back(make_frame(Cmd::kChannelList, std::span(p).first(2 + 2 * n), hh));
  }
  {  // [5] bank list
    std::array<std::uint8_t, 2 + 8> p{};
    put_be16(&p[0], static_cast<std::uint16_t>(2 + n));
    for (std::size_t i = 0; i < n; ++i) {
      p[2 + i] = prog.terminal == Terminal::kRse && prog.channels[i] >= 4 ? 0x02 : 0x00;
    }
    out.push_back(make_frame(Cmd::kBankList, std::span(p).first(2 + n), hh));
  }
  const auto lim_mv = static_cast<std::int32_t>(std::lround(prog.range_v * 1000.0));
  for (std::size_t i = 0; i < n; ++i) {  // [6]
    std::array<std::uint8_t, 8> setup{};
    put_be16(&setup[2], channel_setup_code(prog.channels[i], prog.terminal));
    setup[5] = 0x08;
    out.push_back(make_frame(Cmd::kChannelSetup, setup, hh));
    std::array<std::uint8_t, 16> range{};
    put_be32(&range[0], static_cast<std::uint32_t>(lim_mv));
    put_be32(&range[4], static_cast<std::uint32_t>(-lim_mv));
    range[8] = 0xFD;
    range[9] = 0xFD;
    range[11] = 0x04;
    range[14] = static_cast<std::uint8_t>(i);
    out.push_back(make_frame(Cmd::kRange, range, hh));
  }
  const std::array<std::uint8_t, 4> arm{0x01, 0, 0, 0};
  out.push_back(make_frame(Cmd::kArm, arm, hh));
  std::array<std::uint8_t, 4> clk{};
  put_be32(&clk[0], prog.clock_divisor);
  out.push_back(make_frame(Cmd::kClock, clk, hh));
  out.push_back(make_frame(Cmd::kCommit13, {}, hh));
  out.push_back(make_frame(Cmd::kCommit15, {}, hh));
  return out;
}

std::vector<Frame> start_frames(std::uint32_t scans, std::size_t n_channels, std::uint8_t hh) {
  std::array<std::uint8_t, 4> count{};
  put_be32(&count[0], scans);
  std::array<std::uint8_t, 4> bytes{};
  put_be32(&bytes[0], static_cast<std::uint32_t>(std::uint64_t{scans} * n_channels * 2));
  return {make_frame(Cmd::kScanCount, count, hh), make_frame(Cmd::kByteCount, bytes, hh),
          make_frame(Cmd::kStart0F03, {}, hh),    make_frame(Cmd::kStart0903, {}, hh),
          make_frame(Cmd::kStart0900, {}, hh),    make_frame(Cmd::kStart0A00, {}, hh),
          make_frame(Cmd::kStart1003, {}, hh)};
}

std::vector<Frame> stop_frames(std::uint8_t hh) {
  return {make_frame(Cmd::kSession0B, {}, hh), make_frame(Cmd::kSession0C, {}, hh),
          make_frame(Cmd::kAiReset, {}, hh), make_frame(Cmd::kSession0D, {}, hh)};
}

std::uint32_t max_segment_scans(std::size_t n_channels) {
  return static_cast<std::uint32_t>(std::numeric_limits<std::uint32_t>::max() / (2 * n_channels));
}

Sample decode_sample(const std::uint8_t* word, SampleCoding coding) {
  const auto w = static_cast<std::uint16_t>(coding.order == ByteOrder::kBig
                                                ? (word[0] << 8) | word[1]
                                                : (word[1] << 8) | word[0]);
  const unsigned shift = 16U - coding.bits;
  return {static_cast<std::uint16_t>(w >> shift), (w & ((1U << shift) - 1U)) != 0U};  // [9]
}

Sample decode_usb6008_sample(const std::uint8_t* word, ByteOrder order) {
  return decode_sample(word, usb6008_coding(order));
}

Sample decode_usb6009_sample(const std::uint8_t* word) {
  return decode_sample(word, usb6009_coding());
}

ByteOrderDetector::ByteOrderDetector(unsigned bits, std::size_t n_channels)
    : bits_(bits), n_ch_(std::min(n_channels, kMaxChannels)) {}

bool ByteOrderDetector::feed(const std::uint8_t* words, std::size_t n_scans) {
  bool changed = false;
  const std::size_t stride = 2 * n_ch_;
  for (std::size_t s = 0; s < n_scans; ++s) {
    for (std::size_t c = 0; c < n_ch_; ++c) {
      for (std::size_t o = 0; o < 2; ++o) {
        const Sample v = decode_sample(&words[s * stride + 2 * c], {bits_, o == 0 ? ByteOrder::kBig : ByteOrder::kLittle});
        if (have_prev_) variation_[o] += static_cast<std::uint64_t>(std::abs(int{v.code} - int{prev_[o][c]}));
        prev_[o][c] = v.code;
      }
    }
    have_prev_ = true;
    if (++scans_ < kWindowScans) continue;
    // The window's verdict (0 big, 1 little, -1 none).
    int verdict = -1;
    for (std::size_t o = 0; o < 2 && verdict < 0; ++o) {
      const std::size_t other = 1 - o;
      // Smoothness: one LSB of noise read the wrong way is 2^8 codes; at least one such step.
      // (The padding bits are no evidence: a device may set them, and then the right reading is
      // the one with padding set.)
      if (variation_[o] * 8 <= variation_[other] && variation_[other] >= 256) verdict = static_cast<int>(o);
    }
    if (verdict >= 0) {
      const ByteOrder o = verdict == 0 ? ByteOrder::kBig : ByteOrder::kLittle;
      if (!decided_ || o != order_) {
        if (decided_) ++reversals_;
        decided_ = true;
        order_ = o;
        changed = true;
      }
    }
    scans_ = 0;
    variation_ = {};
  }
  return changed;
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
