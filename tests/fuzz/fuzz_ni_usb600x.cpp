// fuzz-link: pof_daq_protocol
// The NI USB-6008/6009 protocol module (daq/include/pof/daq/protocol/ni_usb600x.hpp), on arbitrary
// bytes read as what the device sends: a reply on endpoint 0x81, a frame, a stream of samples on
// 0x82. Properties:
//  - parse_frame() accepts only frames whose length fields agree with the bytes [3], and a
//    canonical one (padding, the 02 byte and bytes 10-11 as make_frame() writes them) is rebuilt
//    byte for byte by make_frame() from what it parsed;
//  - reply_header() accepts only the reply of the table's length and header for the command [4],
//    which is also a well-formed frame;
//  - make_frame() of any command and parameters parses back to them, or throws std::length_error
//    (its documented error) when they do not fit one 64-byte packet;
//  - every 16-bit word decodes to a code within its bits, encode_sample() writes it back (padding
//    bits cleared), and code -> volts -> code is the identity;
//  - ByteOrderDetector reads only whole scans and reaches the same verdict whether the stream comes
//    in one piece or in the pieces a USB transfer may cut it into (the backend feeds per transfer).
// Seeds: tests/fuzz/corpus/ni_usb600x/ (fuzz_seeds writes them).
#include <algorithm>
#include <cstdint>
#include <span>
#include <stdexcept>

#include "fuzz_check.hpp"
#include "pof/daq/protocol/ni_usb600x.hpp"

namespace ni = pof::daq::ni;

namespace {

void frames(std::span<const std::uint8_t> in) {
  if (const auto p = ni::parse_frame(in)) {
    FUZZ_CHECK(in.size() >= ni::kHeaderBytes && p->hh <= 1);
    FUZZ_CHECK(p->params.data() == in.data() + ni::kHeaderBytes && p->params.size() == in.size() - ni::kHeaderBytes);
    const ni::Opcode* oc = ni::find_opcode(p->op, p->group);
    const bool canonical = oc != nullptr && in.size() <= ni::kMaxPacket && in.size() % 4 == 0 &&
                           in[8] == (oc->cmd == ni::Cmd::kHello ? 0x00 : 0x02) && in[10] == 0 && in[11] == 0;
    if (canonical) {
      const ni::Frame f = ni::make_frame(oc->cmd, p->params, p->hh);
      FUZZ_CHECK(std::ranges::equal(f.view(), in));
    }
  }
  for (const ni::Opcode& oc : ni::kOpcodes) {
    const auto hh = ni::reply_header(oc.cmd, in);
    if (!hh) continue;
    FUZZ_CHECK(*hh <= 1 && in.size() == oc.reply_bytes);
    FUZZ_CHECK(std::ranges::equal(in.first(ni::kHeaderBytes), ni::make_reply(oc.cmd, *hh).view().first(ni::kHeaderBytes)));
    FUZZ_CHECK(ni::parse_frame(in).has_value());
  }
  // The bytes as a command to send: first byte the command, second the header byte, the rest
  // parameters.
  if (in.size() < 2) return;
  const ni::Opcode& oc = ni::kOpcodes[in[0] % ni::kOpcodes.size()];
  const auto hh = static_cast<std::uint8_t>(in[1] & 1U);
  const auto params = in.subspan(2);
  ni::Frame f;
  try {
    f = ni::make_frame(oc.cmd, params, hh);
  } catch (const std::length_error&) {
    FUZZ_CHECK(ni::kHeaderBytes + params.size() > ni::kMaxPacket);
    return;
  }
  const auto p = ni::parse_frame(f.view());
  FUZZ_CHECK(p && p->op == oc.op && p->group == oc.group && p->hh == hh);
  FUZZ_CHECK(p->params.size() >= params.size() && p->params.size() < params.size() + 4);
  FUZZ_CHECK(std::ranges::equal(p->params.first(params.size()), params));
  FUZZ_CHECK(std::ranges::all_of(p->params.subspan(params.size()), [](std::uint8_t b) { return b == 0; }));
}

void samples(std::span<const std::uint8_t> in) {
  for (const ni::SampleCoding coding : {ni::usb6008_coding(ni::ByteOrder::kBig), ni::usb6008_coding(ni::ByteOrder::kLittle),
                                        ni::usb6009_coding()}) {
    const unsigned pad_bits = 16U - coding.bits;
    for (std::size_t i = 0; i + 1 < in.size(); i += 2) {
      const ni::Sample s = ni::decode_sample(&in[i], coding);
      FUZZ_CHECK(s.code < (1U << coding.bits));
      std::uint8_t w[2];
      ni::encode_sample(s.code, coding, w);
      const std::uint8_t low = coding.order == ni::ByteOrder::kBig ? 1 : 0;  // the byte holding the padding
      const auto pad_mask = static_cast<std::uint8_t>((1U << pad_bits) - 1U);
      FUZZ_CHECK(w[1 - low] == in[i + 1 - low] && w[low] == (in[i + low] & ~pad_mask));
      FUZZ_CHECK(s.padding_set == ((in[i + low] & pad_mask) != 0));
      const double v = ni::code_to_volts(s.code, coding.bits, 10.0);
      FUZZ_CHECK(v >= -10.0 && v < 10.0);
      FUZZ_CHECK(ni::volts_to_code(v, coding.bits, 10.0) == s.code);
    }
  }
}

void byte_order(std::span<const std::uint8_t> in) {
  // Cut points of the stream: from the first byte, 1..16 scans per piece.
  const std::size_t step = in.empty() ? 1 : in[0] % 16U + 1U;
  for (const std::size_t n_ch : {std::size_t{1}, std::size_t{3}, std::size_t{8}}) {
    const std::size_t scans = in.size() / (2 * n_ch);
    ni::ByteOrderDetector whole(12, n_ch);
    ni::ByteOrderDetector pieces(12, n_ch);
    whole.feed(in.data(), scans);
    for (std::size_t s = 0; s < scans; s += step) pieces.feed(in.data() + 2 * n_ch * s, std::min(step, scans - s));
    FUZZ_CHECK(whole.decided() == pieces.decided() && whole.order() == pieces.order());
    FUZZ_CHECK(whole.reversals() == pieces.reversals() && whole.reversals() >= 0);
    // Undecided: no reversal, and the 6009's order [C]; a verdict needs a whole window.
    FUZZ_CHECK(whole.decided() || (whole.reversals() == 0 && whole.order() == ni::ByteOrder::kBig));
    FUZZ_CHECK(!whole.decided() || scans >= ni::ByteOrderDetector::kWindowScans);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> in(data, size);
  frames(in);
  samples(in);
  byte_order(in);
  return 0;
}
