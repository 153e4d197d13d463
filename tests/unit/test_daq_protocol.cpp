// The DAQ protocol modules against the byte sequences of the public captures
// (daq/include/pof/daq/protocol/ni_usb600x.hpp [1]-[9], mcc_usb1208ls.hpp [1]-[7]) and their own inverses.
#include <gtest/gtest.h>

#include <vector>

#include "pof/daq/protocol/mcc_usb1208ls.hpp"
#include "pof/daq/protocol/ni_usb600x.hpp"

namespace ni = pof::daq::ni;
namespace mcc = pof::daq::mcc;

namespace {
std::vector<std::uint8_t> bytes(const ni::Frame& f) { return {f.bytes.begin(), f.bytes.begin() + static_cast<long>(f.size)}; }
using B = std::vector<std::uint8_t>;
}  // namespace

TEST(NiUsb600x, FramesMatchTheCapturedSession) {
  // [C] ni_usb6009.c request templates, byte for byte.
  EXPECT_EQ(bytes(ni::make_frame(ni::Cmd::kHello)), (B{0, 0, 0, 0x0C, 0, 0x08, 0x01, 0x00, 0x00, 0, 0, 0}));
  const auto s = ni::session_frames();
  ASSERT_EQ(s.size(), 3U);
  EXPECT_EQ(bytes(s[0]), (B{0, 0, 0, 0x0C, 0, 0x08, 0x01, 0x0B, 0x02, 0, 0, 0}));
  // [3] a device whose replies begin 00 01 is spoken to with 00 01 (the 6008 sources).
  EXPECT_EQ(bytes(ni::session_frames(1)[0]), (B{0, 1, 0, 0x0C, 0, 0x08, 0x01, 0x0B, 0x02, 0, 0, 0}));
  EXPECT_EQ(ni::parse_frame(bytes(ni::session_frames(1)[0]))->hh, 1);
}

TEST(NiUsb600x, EightChannelScanProgrammeMatchesTheCapture) {
  ni::ScanProgram p;
  p.channels = {0, 1, 2, 3, 4, 5, 6, 7};
  p.clock_divisor = ni::clock_divisor(1000.0);
  EXPECT_EQ(p.clock_divisor, 0x5DC0U);  // [7]
  const auto f = ni::configure_frames(p);
  ASSERT_EQ(f.size(), 1U + 2U + 16U + 4U);
  EXPECT_EQ(bytes(f[0]), (B{0, 0, 0, 0x0C, 0, 0x08, 0x01, 0x0C, 0x02, 0x03, 0, 0}));
  EXPECT_EQ(bytes(f[1]), (B{0, 0, 0, 0x20, 0, 0x1C, 0x01, 0x0F, 0x02, 0x02, 0, 0, 0, 0x12, 0, 0, 0, 1, 0, 2,
                            0, 3, 0, 4, 0, 5, 0, 6, 0, 7, 0, 0}));
  EXPECT_EQ(bytes(f[2]), (B{0, 0, 0, 0x18, 0, 0x14, 0x01, 0x0E, 0x02, 0x02, 0, 0, 0, 0x0A, 0, 0, 0, 0, 2, 2,
                            2, 2, 0, 0}));
  EXPECT_EQ(bytes(f[3]), (B{0, 0, 0, 0x14, 0, 0x10, 0x01, 0x14, 0x02, 0x04, 0, 0, 0, 0, 0, 0x30, 0, 0x08, 0, 0}));
  EXPECT_EQ(bytes(f[4]), (B{0, 0, 0, 0x1C, 0, 0x18, 0x01, 0x10, 0x02, 0x02, 0, 0, 0, 0, 0x27, 0x10, 0xFF, 0xFF,
                            0xD8, 0xF0, 0xFD, 0xFD, 0, 0x04, 0, 0, 0, 0}));
  // ai4: bank 2 setup code 0x118 [6]; range frame carries the list position.
  EXPECT_EQ(f[3 + 8].bytes[14], 0x01);
  EXPECT_EQ(f[3 + 8].bytes[15], 0x18);
  EXPECT_EQ(f[4 + 8].bytes[26], 4);
  EXPECT_EQ(bytes(f[19]), (B{0, 0, 0, 0x10, 0, 0x0C, 0x01, 0x0E, 0x02, 0x00, 0, 0, 0x01, 0, 0, 0}));
  EXPECT_EQ(bytes(f[20]), (B{0, 0, 0, 0x10, 0, 0x0C, 0x01, 0x16, 0x02, 0x00, 0, 0, 0, 0, 0x5D, 0xC0}));
}

TEST(NiUsb600x, StartFramesCarryCountAndBytes) {
  const auto f = ni::start_frames(1000, 8);
  ASSERT_EQ(f.size(), 7U);
  EXPECT_EQ(bytes(f[0]), (B{0, 0, 0, 0x10, 0, 0x0C, 0x01, 0x0F, 0x02, 0x00, 0, 0, 0, 0, 0x03, 0xE8}));
  EXPECT_EQ(bytes(f[1]), (B{0, 0, 0, 0x10, 0, 0x0C, 0x01, 0x12, 0x02, 0x03, 0, 0, 0, 0, 0x3E, 0x80}));
  EXPECT_EQ(f[6].bytes[7], 0x10);
  EXPECT_EQ(f[6].bytes[9], 0x03);
  EXPECT_GE(ni::max_segment_scans(3) * 3ULL * 2ULL, 4294967290ULL);  // [10] uses the whole BE32
}

TEST(NiUsb600x, RepliesAndParsing) {
  const B ack{0, 0, 0, 0x0C, 0, 0x08, 0x01, 0, 0, 0, 0, 0x02};  // [4]
  EXPECT_TRUE(ni::reply_ok(ni::Cmd::kArm, ack));
  EXPECT_EQ(ni::reply_header(ni::Cmd::kArm, ack), 0);
  // [3][4]: the 6008 sources' replies begin 00 01; accepted, and the byte reported.
  auto ack01 = ack;
  ack01[1] = 0x01;
  EXPECT_EQ(ni::reply_header(ni::Cmd::kArm, ack01), 1);
  ack01[1] = 0x02;
  EXPECT_FALSE(ni::reply_ok(ni::Cmd::kArm, ack01));
  EXPECT_FALSE(ni::reply_ok(ni::Cmd::kHello, ack));  // hello answers 0x1C bytes
  EXPECT_EQ(bytes(ni::make_reply(ni::Cmd::kArm)), ack);
  EXPECT_EQ(ni::make_reply(ni::Cmd::kHello).size, 0x1CU);
  EXPECT_EQ(ni::make_reply(ni::Cmd::kChannelSetup).size, 0x18U);
  B garbage = ack;
  garbage[11] = 0x03;
  EXPECT_FALSE(ni::reply_ok(ni::Cmd::kArm, garbage));
  const ni::Frame f = ni::make_frame(ni::Cmd::kClock, B{0, 0, 0x5D, 0xC0});
  const auto p = ni::parse_frame(f.view());
  ASSERT_TRUE(p);
  EXPECT_EQ(p->op, 0x16);
  EXPECT_EQ(ni::find_opcode(p->op, p->group)->cmd, ni::Cmd::kClock);
  B bad = bytes(f);
  bad[3] = 0x11;  // length field disagrees
  EXPECT_FALSE(ni::parse_frame(bad));
  EXPECT_FALSE(ni::parse_frame(B{0, 0, 0}));
  // Every opcode/group pair is in the table once.
  for (const auto& a : ni::kOpcodes) {
    EXPECT_EQ(ni::find_opcode(a.op, a.group), &a) << a.name;
  }
}

TEST(NiUsb600x, Usb6009SampleIsBigEndian14BitLeftJustified) {
  const std::uint8_t w[2] = {0x80, 0x00};  // mid-scale
  EXPECT_EQ(ni::decode_usb6009_sample(w).code, 0x2000);
  EXPECT_FALSE(ni::decode_usb6009_sample(w).padding_set);
  const std::uint8_t top[2] = {0xFF, 0xFC};
  EXPECT_EQ(ni::decode_usb6009_sample(top).code, 0x3FFF);
  // A padding bit set: no source checks it ([9]); the value is kept and the bit reported.
  const std::uint8_t pad[2] = {0x80, 0x01};
  EXPECT_EQ(ni::decode_usb6009_sample(pad).code, 0x2000);
  EXPECT_TRUE(ni::decode_usb6009_sample(pad).padding_set);
  EXPECT_DOUBLE_EQ(ni::code_to_volts(0x2000, 14, 10.0), 0.0);
  EXPECT_DOUBLE_EQ(ni::code_to_volts(0, 14, 10.0), -10.0);
}

TEST(NiUsb600x, Usb6008SampleByteOrderIsOneSwitch) {
  const std::uint8_t be[2] = {0x81, 0x10};  // 0x811 << 4
  EXPECT_EQ(ni::decode_usb6008_sample(be, ni::ByteOrder::kBig).code, 0x811);
  const std::uint8_t le[2] = {0x10, 0x80};
  EXPECT_EQ(ni::decode_usb6008_sample(le, ni::ByteOrder::kLittle).code, 0x801);
  EXPECT_TRUE(ni::decode_usb6008_sample(be, ni::ByteOrder::kLittle).padding_set);  // 0x1081
  EXPECT_NEAR(ni::code_to_volts(2048, 12, 10.0), 0.0, 1e-12);
  EXPECT_NEAR(ni::lsb_volts(12, 10.0), 20.0 / 4096, 1e-15);
}

// [9] the byte order told from the data, in each order, with zero and with nonzero padding.
TEST(NiUsb600x, ByteOrderIsToldFromTheData) {
  for (const auto order : {ni::ByteOrder::kBig, ni::ByteOrder::kLittle}) {
    for (const bool pad : {false, true}) {
      ni::ByteOrderDetector d(12, 3);
      std::vector<std::uint8_t> w(2 * 3 * ni::ByteOrderDetector::kWindowScans);
      for (std::size_t s = 0; s < ni::ByteOrderDetector::kWindowScans; ++s) {
        for (std::size_t c = 0; c < 3; ++c) {
          // +0.03 V (code 0x806) with +-1 LSB of noise: the case a padding check alone misses.
          const auto code = static_cast<std::uint16_t>(0x806 + static_cast<int>((s * 7 + c) % 3) - 1);
          std::uint8_t* p = &w[2 * (3 * s + c)];
          ni::encode_sample(code, ni::usb6008_coding(order), p);
          if (pad) p[order == ni::ByteOrder::kBig ? 1 : 0] |= static_cast<std::uint8_t>((s + c) % 16);
        }
      }
      EXPECT_FALSE(d.decided());
      EXPECT_TRUE(d.feed(w.data(), ni::ByteOrderDetector::kWindowScans));
      ASSERT_TRUE(d.decided());
      EXPECT_EQ(d.order(), order) << "pad " << pad;
    }
  }
  // A signal without noise or motion cannot tell: undecided (the daemon flags such blocks).
  ni::ByteOrderDetector d(12, 1);
  std::vector<std::uint8_t> w(2 * ni::ByteOrderDetector::kWindowScans);
  for (std::size_t s = 0; s < ni::ByteOrderDetector::kWindowScans; ++s) {
    ni::encode_sample(0x806, ni::usb6008_coding(ni::ByteOrder::kLittle), &w[2 * s]);
  }
  EXPECT_FALSE(d.feed(w.data(), ni::ByteOrderDetector::kWindowScans));
  EXPECT_FALSE(d.decided());
}

TEST(NiUsb600x, EncodeDecodeRoundTripWithinHalfAnLsb) {
  for (const auto coding : {ni::usb6008_coding(ni::ByteOrder::kBig), ni::usb6008_coding(ni::ByteOrder::kLittle),
                            ni::usb6009_coding()}) {
    for (double v = -10.0; v <= 9.99; v += 0.0137) {
      std::uint8_t w[2];
      ni::encode_sample(ni::volts_to_code(v, coding.bits, 10.0), coding, w);
      const auto c = ni::decode_sample(w, coding);
      ASSERT_FALSE(c.padding_set);
      EXPECT_LE(std::abs(ni::code_to_volts(c.code, coding.bits, 10.0) - v), ni::lsb_volts(coding.bits, 10.0) / 2 + 1e-12);
    }
  }
  EXPECT_EQ(ni::volts_to_code(50.0, 12, 10.0), 4095);  // clamped
  EXPECT_EQ(ni::volts_to_code(-50.0, 12, 10.0), 0);
}

TEST(MccUsb1208ls, AInDecodersMatchThePublicDriver) {
  // [5]: differential 12-bit two's complement, SE 11-bit offset by 0x400.
  EXPECT_EQ(mcc::decode_ain_differential(0x0F, 0x7F), 0x7FF);
  EXPECT_EQ(mcc::decode_ain_differential(0x00, 0x80), -2048);
  EXPECT_EQ(mcc::decode_ain_single_ended(0x0F, 0x7F), 0x7FF - 0x400);
  EXPECT_EQ(mcc::decode_ain_single_ended(0x00, 0x40), 0);
  EXPECT_NEAR(mcc::counts_to_volts(0x3FF, mcc::kSe10V), 10.0, 1e-12);
  EXPECT_NEAR(mcc::counts_to_volts(0x7FF, mcc::kBp5V), 5.0, 1e-12);
}

TEST(MccUsb1208ls, ScanReportRoundTripAndPacking) {
  std::array<std::int16_t, 64> s{};
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = static_cast<std::int16_t>(static_cast<int>(i) * 61 - 2048);
  std::array<std::uint8_t, 105> r{};
  mcc::encode_scan_report(s, 0x1234, 7, r);
  EXPECT_EQ(r[102], 0x34);
  EXPECT_EQ(r[103], 0x12);
  // [7]: s0 = b0 | (b1 & 0xF0) << 4, s1 = b2 | (b1 & 0x0F) << 8
  EXPECT_EQ(static_cast<int>(r[1] | ((r[2] & 0xF0) << 4)), static_cast<int>(static_cast<unsigned>(s[0]) & 0xFFF));
  std::array<std::int16_t, 64> back{};
  EXPECT_EQ(mcc::decode_scan_report(r, back), 0x1234);
  EXPECT_EQ(back, s);
  // [7] the data-first layout (wjasper usb_1208LS.py, ryan-duve): data from 0, index at 101.
  mcc::encode_scan_report(s, 0x1234, 7, r, mcc::ReportLayout::kDataFirst);
  EXPECT_EQ(r[101], 0x34);
  EXPECT_EQ(r[102], 0x12);
  EXPECT_EQ(static_cast<int>(r[0] | ((r[1] & 0xF0) << 4)), static_cast<int>(static_cast<unsigned>(s[0]) & 0xFFF));
  back = {};
  EXPECT_EQ(mcc::decode_scan_report(r, back, mcc::ReportLayout::kDataFirst), 0x1234);
  EXPECT_EQ(back, s);
}

TEST(MccUsb1208ls, ReportLayoutIsToldFromTheScanIndex) {
  for (const auto layout : {mcc::ReportLayout::kRecordFirst, mcc::ReportLayout::kDataFirst}) {
    mcc::LayoutDetector d;
    std::array<std::int16_t, 64> s{};
    std::array<std::uint8_t, 105> r{};
    EXPECT_FALSE(d.is_next(r, 1));  // a report of zeros (nothing scanned yet) is not the next
    for (std::uint16_t i = 1; i <= 2; ++i) {
      for (auto& v : s) v = static_cast<std::int16_t>(i * 100);  // data that could look like an index
      mcc::encode_scan_report(s, i, static_cast<std::uint8_t>(i), r, layout);
      ASSERT_TRUE(d.is_next(r, i));
      EXPECT_FALSE(d.is_next(r, static_cast<std::uint16_t>(i + 1)));  // a repeat is not the next
      d.accept(r, i);
    }
    ASSERT_TRUE(d.decided());
    EXPECT_EQ(d.layout(), layout);
  }
}

TEST(MccUsb1208ls, A104ByteReportIsDataFirstByItsLength) {
  // [7] wjasper's Python port reads 104 bytes on the wire (get_feature_report(0, 105) counts
  // the report id) and unpacks the C struct without its record number.
  EXPECT_EQ(mcc::layout_for_size(104), mcc::ReportLayout::kDataFirst);
  EXPECT_FALSE(mcc::layout_for_size(105));  // either layout: told from the scan index
  EXPECT_TRUE(mcc::is_scan_report_size(104));
  EXPECT_TRUE(mcc::is_scan_report_size(105));
  EXPECT_FALSE(mcc::is_scan_report_size(103));
  EXPECT_FALSE(mcc::is_scan_report_size(106));
  std::array<std::int16_t, 64> s{};
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = static_cast<std::int16_t>(static_cast<int>(i) * 53 - 1700);
  std::array<std::uint8_t, 105> r{};
  mcc::encode_scan_report(s, 0x0203, 0, r, mcc::ReportLayout::kDataFirst);
  r[104] = 0xEE;  // not on the wire: whatever the 105th byte holds, nothing reads it
  std::array<std::int16_t, 64> back{};
  EXPECT_EQ(mcc::decode_scan_report(r, back, mcc::ReportLayout::kDataFirst), 0x0203);
  EXPECT_EQ(back, s);
  mcc::LayoutDetector d;
  d.force(mcc::ReportLayout::kDataFirst);
  EXPECT_TRUE(d.decided());
  EXPECT_EQ(d.layout(), mcc::ReportLayout::kDataFirst);
}

TEST(MccUsb1208ls, SingleEndedScanCodingIsToldFromAnAInReading) {
  // [5][7] an AIn reading of +3.00 V single-ended: 307 counts (x 10 / 0x3FF).
  const std::int16_t ain = 307;
  // The same input in a scan field, two's complement (307) or offset like the AIn reply (307 + 0x400).
  EXPECT_EQ(mcc::se_scan_coding_from(ain, 305), mcc::SeScanCoding::kTwosComplement);
  EXPECT_EQ(mcc::se_scan_coding_from(ain, 305 + 0x400), mcc::SeScanCoding::kOffset);
  // Read the other way the offset field is 13.0 V: over range, never a value.
  EXPECT_EQ(mcc::se_scan_counts(307 + 0x400, mcc::SeScanCoding::kTwosComplement), 307 + 0x400);
  EXPECT_EQ(mcc::se_scan_counts(307 + 0x400, mcc::SeScanCoding::kOffset), 307);
  // Negative inputs: -5 V = -512 counts.
  EXPECT_EQ(mcc::se_scan_coding_from(-512, mcc::scan_field12(-510)), mcc::SeScanCoding::kTwosComplement);
  EXPECT_EQ(mcc::se_scan_coding_from(-512, static_cast<unsigned>(-510 + 0x400)), mcc::SeScanCoding::kOffset);
  // The input moved by 5 V between the readings: neither coding within 2.5 V, no verdict.
  EXPECT_FALSE(mcc::se_scan_coding_from(ain, static_cast<unsigned>(307 + 0x200)));
}

TEST(MccUsb1208ls, QueueLengthAndVoltsFactors) {
  // [3]: the queue holds 1, 2, 4 or 8 entries (wjasper usb-1208LS.c, usb_1208LS.py).
  EXPECT_EQ(mcc::queue_length(1), 1U);
  EXPECT_EQ(mcc::queue_length(3), 4U);
  EXPECT_EQ(mcc::queue_length(5), 8U);
  EXPECT_EQ(mcc::queue_length(9), 0U);
  // [5] wjasper volts_LS: single-ended x 10 / 0x3FF, differential x range / 0x7FF, for scans too.
  EXPECT_NEAR(mcc::scan_counts_to_volts(0x3FF, mcc::kSe10V), 10.0, 1e-12);
  EXPECT_NEAR(mcc::scan_counts_to_volts(-0x400, mcc::kSe10V), -10.0 * 0x400 / 0x3FF, 1e-12);
  EXPECT_NEAR(mcc::scan_counts_to_volts(0x7FF, mcc::kBp10V), 10.0, 1e-12);
}

TEST(MccUsb1208ls, ScanTimerBandsAndQueue) {
  const auto t = mcc::scan_timer(1000);  // 800-1500 Hz: prescale 4, setup 1 [6]
  ASSERT_TRUE(t);
  EXPECT_EQ(t->prescale, 4);
  // 6e6 / (1000 * 32) = 187.5 counts: timer = 256 - 187.5 rounded up = 69, preload = 69 + 1.
  EXPECT_EQ(t->preload, 70);
  EXPECT_NEAR(t->actual_rate_hz, 6e6 / (32.0 * 187), 1e-9);
  EXPECT_FALSE(mcc::scan_timer(50));
  EXPECT_FALSE(mcc::scan_timer(9000));
  std::array<mcc::OutReport, 2> q{};
  const std::uint8_t ch8[8] = {0, 1, 2, 3, 4, 5, 6, 7};
  EXPECT_EQ(mcc::load_queue_reports(ch8, mcc::kSe10V, q), 2U);
  EXPECT_EQ(q[0][1], mcc::kALoadQueue);
  EXPECT_EQ(q[0][2], 8);
  EXPECT_EQ(q[0][3], 0x88);
  EXPECT_EQ(q[1][2], 2);
  EXPECT_EQ(q[1][4], 0x8F);
  // The queue holds 1 to 8 entries [3]: other lengths are refused (13 used to write past `q`;
  // found by tests/fuzz/fuzz_mcc_usb1208ls.cpp).
  const std::uint8_t ch13[13] = {};
  for (const std::size_t n : {0U, 9U, 12U, 13U}) {
    EXPECT_THROW(mcc::load_queue_reports(std::span(ch13, n), mcc::kSe10V, q), std::invalid_argument) << n;
  }
  EXPECT_EQ(mcc::gain_for(true, 2.5), mcc::kBp2_5V);
  EXPECT_FALSE(mcc::gain_for(false, 5.0));
}
