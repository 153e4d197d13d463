// The bounded decoder (lcmtypes/include/pof/lcm/decode.hpp): every pofkit type round-trips; every
// truncation, negative or oversized length, bad string and wrong fingerprint is a counted error,
// never an exception, and costs at most a bounded allocation. Allocations are counted with a
// replaced global operator new, armed only around the decode under test.
// GCC inlines gtest's `delete` of a `new`ed test object into our free() and misreports it.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <string>
#include <vector>

#include "pof/lcm/decode.hpp"

namespace {
std::atomic<bool> g_armed{false};
std::atomic<std::uint64_t> g_bytes{0};
}  // namespace

void* operator new(std::size_t n) {
  if (g_armed.load()) g_bytes += n;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace {

using pof::lcmutil::DecodeError;
using pof::lcmutil::DecodeResult;

using Bytes = std::vector<unsigned char>;

template <class T>
Bytes encode(const T& m) {
  Bytes b(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

// Decodes with the allocation counter armed; returns the result and the bytes allocated.
template <class T>
DecodeResult decode_counted(const Bytes& b, std::uint64_t& allocated) {
  T m;
  g_bytes = 0;
  g_armed = true;
  const DecodeResult r = pof::lcmutil::decode(b.data(), b.size(), m);
  g_armed = false;
  allocated = g_bytes.load();
  return r;
}

// Big-endian writer for hand-made (hostile) messages.
struct Writer {
  Bytes b;
  void be(std::uint64_t v, int n) {
    for (int i = n - 1; i >= 0; --i) b.push_back(static_cast<unsigned char>(v >> (8 * i)));
  }
  void i8(std::int8_t v) { be(static_cast<std::uint8_t>(v), 1); }
  void i16(std::int16_t v) { be(static_cast<std::uint16_t>(v), 2); }
  void i32(std::int32_t v) { be(static_cast<std::uint32_t>(v), 4); }
  void i64(std::int64_t v) { be(static_cast<std::uint64_t>(v), 8); }
  void f32(float v) {
    std::uint32_t u = 0;
    std::memcpy(&u, &v, 4);
    be(u, 4);
  }
  void f64(double v) {
    std::uint64_t u = 0;
    std::memcpy(&u, &v, 8);
    be(u, 8);
  }
  void str(const std::string& s) {
    i32(static_cast<std::int32_t>(s.size() + 1));
    b.insert(b.end(), s.begin(), s.end());
    b.push_back(0);
  }
};

// A raw_block_t written field by field, so any field can carry any value.
struct RawSpec {
  std::int32_t sensor_id_len = -2;  // -2: a proper "LK"
  bool embedded_nul = false;        // "L\0" + NUL instead of "LK" + NUL
  std::int16_t n_channels = 2;
  std::vector<std::string> names{"sensor", "reference"};
  std::int32_t name0_len = -2;  // -2: proper
  std::int32_t n_scans = 3;
  std::size_t volts_written = 6;
};
Bytes raw_block(const RawSpec& s) {
  Writer w;
  w.i64(pof::raw_block_t::getHash());
  w.i64(1'700'000'000'000'000);  // utime
  w.i64(1'700'000'000'001'000);  // publish_utime
  w.i64(7);                      // seq
  w.i64(70);                     // first_scan
  w.f64(200.0);
  if (s.sensor_id_len == -2) {
    w.str("LK");
  } else {
    w.i32(s.sensor_id_len);
    w.b.insert(w.b.end(), {'L', static_cast<unsigned char>(s.embedded_nul ? 0 : 'K'), 0});
  }
  w.i16(s.n_channels);
  for (int rep = 0; rep < 2; ++rep)  // channel_names, channel_units
    for (std::size_t i = 0; i < s.names.size(); ++i) {
      if (i == 0 && rep == 0 && s.name0_len != -2) {
        w.i32(s.name0_len);
        w.b.insert(w.b.end(), s.names[0].begin(), s.names[0].end());
        w.b.push_back(0);
      } else {
        w.str(rep == 0 ? s.names[i] : "V");
      }
    }
  w.i32(s.n_scans);
  for (std::size_t i = 0; i < s.volts_written; ++i) w.f32(0.5f * static_cast<float>(i));
  w.i32(pof::raw_block_t::FLAG_SIMULATED);
  return w.b;
}

pof::raw_block_t sample_raw() {
  pof::raw_block_t m;
  m.utime = 1'763'700'000'123'456;
  m.publish_utime = m.utime + 1234;
  m.seq = 42;
  m.first_scan = 4200;
  m.scan_rate_hz = 1000.0;
  m.sensor_id = "LEFT_KNEE_WITH_A_LONG_NAME";  // beyond the small-string buffer
  m.n_channels = 3;
  m.channel_names = {"sensor", "reference", "pot"};
  m.channel_units = {"V", "V", ""};
  m.n_scans = 5;
  for (int k = 0; k < 5; ++k) m.volts.push_back({0.1f * float(k), 4.0f, -1.5f});
  m.flags = pof::raw_block_t::FLAG_GAP;
  return m;
}
pof::angle_t sample_angle() {
  pof::angle_t m;
  m.utime = 11;
  m.publish_utime = 12;
  m.seq = 13;
  m.scan_index = 14;
  m.angle_deg = 45.5f;
  m.angle_uncomp_deg = 46.25f;
  m.angle_ref_deg = std::nanf("");
  m.velocity_rad_s = -1.25f;
  m.phase = pof::angle_t::PHASE_EXTENSION;
  m.quality = int32_t{pof::angle_t::QUALITY_GAP} | int32_t{pof::angle_t::QUALITY_SETTLING};
  return m;
}
pof::cycle_stats_t sample_cycle() {
  pof::cycle_stats_t m{};
  m.utime = 21;
  m.seq = 22;
  m.cycle = 23;
  m.start_utime = 24;
  m.end_utime = 25;
  m.velocity_rad_s = 0.5f;
  m.rmse_comp_deg = 1.5f;
  m.rmse_uncomp_deg = 2.5f;
  m.hysteresis_comp_pct = 3.5f;
  m.hysteresis_uncomp_pct = 4.5f;
  m.max_error_deg = 5.5f;
  m.n_samples = 26;
  return m;
}
pof::daq_status_t sample_daq() {
  pof::daq_status_t m{};
  m.utime = 31;
  m.seq = 32;
  m.sensor_id = "RIGHT_KNEE";
  m.device_kind = "usb6008";
  m.vendor_id = 0x3923;
  m.product_id = 0x717a;
  m.serial = "01ABCDEF";
  m.state = pof::daq_status_t::STATE_STREAMING;
  m.state_text = "streaming at 1000 scans/s from a device with a long state text";
  m.scan_rate_hz = 1000;
  m.n_channels = 3;
  m.scans = 33;
  m.blocks = 34;
  m.dropped_scans = 35;
  m.usb_errors = 36;
  m.overruns = 37;
  m.reconnects = 38;
  m.protocol_variant = "reply header 00 01";
  m.padding_set = 39;
  m.publish_failures = 40;
  return m;
}
pof::compensator_status_t sample_comp() {
  pof::compensator_status_t m{};
  m.utime = 41;
  m.seq = 42;
  m.sensor_id = "LEFT_KNEE";
  m.calibration_path = "/etc/pof/calibration/left_knee.toml";
  m.calibration_sensor_id = "LK-2026";
  m.calibration_date = "2026-11-21T00:00:00Z";
  m.blocks = 43;
  m.scans = 44;
  m.lost_blocks = 45;
  m.lost_scans = 46;
  m.rejected_blocks = 47;
  m.fault_scans = 48;
  m.angles = 49;
  m.cycles = 50;
  m.reloads = 51;
  m.reload_failures = 52;
  m.last_error = "";
  m.decode_errors = 53;
  m.malformed_datagrams = 54;
  m.duplicate_blocks = 55;
  m.publish_failures = 56;
  m.authenticated = true;
  m.auth_unsigned = 57;
  m.auth_bad_mac = 58;
  m.auth_stale = 59;
  m.auth_replayed = 60;
  return m;
}

// Every truncation and one trailing byte are errors; none throws; none allocates more than the
// budget for the bytes at hand.
template <class T>
void expect_truncations_rejected(const T& msg) {
  const Bytes full = encode(msg);
  for (std::size_t n = 0; n < full.size(); ++n) {
    const Bytes cut(full.begin(), full.begin() + static_cast<long>(n));
    std::uint64_t alloc = 0;
    const DecodeResult r = decode_counted<T>(cut, alloc);
    ASSERT_FALSE(r) << pof::lcmutil::Layout<T>::kName << " cut to " << n << " bytes decoded";
    EXPECT_NE(r.error, DecodeError::kDecoderFailed) << r.describe();
    EXPECT_LE(alloc, pof::lcmutil::kHeapFloorBytes + pof::lcmutil::kHeapPerByte * n);
  }
  Bytes longer = full;
  longer.push_back(0);
  T m;
  EXPECT_EQ(pof::lcmutil::decode(longer.data(), longer.size(), m).error, DecodeError::kTrailingBytes);
  Bytes wrong = full;
  wrong[3] ^= 0x40;
  EXPECT_EQ(pof::lcmutil::decode(wrong.data(), wrong.size(), m).error, DecodeError::kHashMismatch);
}

template <class T>
T round_trip(const T& msg) {
  const Bytes b = encode(msg);
  T back;
  const DecodeResult r = pof::lcmutil::decode(b.data(), b.size(), back);
  EXPECT_TRUE(r) << r.describe();
  EXPECT_EQ(encode(back), b) << pof::lcmutil::Layout<T>::kName;  // field for field, bit for bit
  return back;
}

}  // namespace

// The layouts are the .lcm files: the fingerprint computed from them is lcm-gen's.
TEST(LcmDecode, LayoutsMatchTheGeneratedTypes) {
  using namespace pof::lcmutil;
  EXPECT_EQ(detail::layout_hash(Layout<pof::raw_block_t>::kFields), pof::raw_block_t::getHash());
  EXPECT_EQ(detail::layout_hash(Layout<pof::angle_t>::kFields), pof::angle_t::getHash());
  EXPECT_EQ(detail::layout_hash(Layout<pof::cycle_stats_t>::kFields), pof::cycle_stats_t::getHash());
  EXPECT_EQ(detail::layout_hash(Layout<pof::daq_status_t>::kFields), pof::daq_status_t::getHash());
  EXPECT_EQ(detail::layout_hash(Layout<pof::compensator_status_t>::kFields), pof::compensator_status_t::getHash());
  EXPECT_TRUE(layout_matches<pof::raw_block_t>());
  EXPECT_TRUE(layout_matches<pof::angle_t>());
  EXPECT_TRUE(layout_matches<pof::cycle_stats_t>());
  EXPECT_TRUE(layout_matches<pof::daq_status_t>());
  EXPECT_TRUE(layout_matches<pof::compensator_status_t>());
  // A layout with a field renamed, retyped or a dimension changed has another fingerprint.
  static constexpr FieldSpec kRenamed[] = {{"utime", FieldType::kInt64, {}}, {"sequence", FieldType::kInt64, {}}};
  static constexpr FieldSpec kOriginal[] = {{"utime", FieldType::kInt64, {}}, {"seq", FieldType::kInt64, {}}};
  static constexpr FieldSpec kRetyped[] = {{"utime", FieldType::kInt64, {}}, {"seq", FieldType::kInt32, {}}};
  EXPECT_NE(detail::layout_hash(kRenamed), detail::layout_hash(kOriginal));
  EXPECT_NE(detail::layout_hash(kRetyped), detail::layout_hash(kOriginal));
}

TEST(LcmDecode, EveryTypeRoundTrips) {
  const auto raw = round_trip(sample_raw());
  EXPECT_EQ(raw.volts[4][0], 0.4f);
  EXPECT_EQ(raw.channel_units[2], "");
  EXPECT_EQ(raw.sensor_id, "LEFT_KNEE_WITH_A_LONG_NAME");
  EXPECT_EQ(round_trip(sample_angle()).phase, pof::angle_t::PHASE_EXTENSION);
  EXPECT_EQ(round_trip(sample_cycle()).n_samples, 26);
  EXPECT_EQ(round_trip(sample_daq()).protocol_variant, "reply header 00 01");
  const auto comp = round_trip(sample_comp());
  EXPECT_EQ(comp.duplicate_blocks, 55);
  EXPECT_EQ(comp.publish_failures, 56);
  EXPECT_TRUE(comp.authenticated);
  EXPECT_EQ(comp.auth_bad_mac, 58);
  EXPECT_EQ(comp.auth_replayed, 60);  // the last field, behind a string and a boolean
  EXPECT_EQ(round_trip(sample_daq()).publish_failures, 40);
  EXPECT_EQ(comp.last_error, "");
  // The hand-made writer agrees with the generated encoder.
  pof::raw_block_t m;
  const Bytes b = raw_block(RawSpec{});
  ASSERT_TRUE(pof::lcmutil::decode(b.data(), b.size(), m));
  EXPECT_EQ(m.sensor_id, "LK");
  EXPECT_EQ(m.volts[2][1], 2.5f);
  EXPECT_EQ(encode(m), b);
}

TEST(LcmDecode, EveryTruncationOfEveryTypeIsAnError) {
  expect_truncations_rejected(sample_raw());
  expect_truncations_rejected(sample_angle());
  expect_truncations_rejected(sample_cycle());
  expect_truncations_rejected(sample_daq());
  expect_truncations_rejected(sample_comp());
}

TEST(LcmDecode, AnotherTypeIsAFingerprintMismatch) {
  const Bytes a = encode(sample_angle());
  pof::cycle_stats_t c;
  const DecodeResult r = pof::lcmutil::decode(a.data(), a.size(), c);
  EXPECT_EQ(r.error, DecodeError::kHashMismatch);
  EXPECT_NE(r.describe().find("not a cycle_stats_t"), std::string::npos) << r.describe();
  const Bytes garbage{1, 2, 3};
  EXPECT_EQ(pof::lcmutil::decode(garbage.data(), garbage.size(), c).error, DecodeError::kTooShort);
  EXPECT_EQ(pof::lcmutil::decode(nullptr, 0, c).error, DecodeError::kTooShort);
}

// The datagrams that took pof-compensatord down before (std::bad_alloc, 1.18 GB): each is now an
// error naming the field, and costs (almost) nothing.
TEST(LcmDecode, HostileRawBlockLengthsAreErrorsWithoutAllocation) {
  struct Case {
    const char* what;
    RawSpec spec;
    DecodeError want;
    const char* field;
  };
  std::vector<Case> cases;
  auto with = [](auto f) {
    RawSpec s;
    f(s);
    return s;
  };
  cases.push_back({"n_scans 2^31-1", with([](RawSpec& s) { s.n_scans = std::numeric_limits<std::int32_t>::max(); }),
                   DecodeError::kBadLength, "volts"});
  cases.push_back({"n_scans -1", with([](RawSpec& s) { s.n_scans = -1; }), DecodeError::kBadLength, "volts"});
  cases.push_back({"n_scans INT32_MIN", with([](RawSpec& s) { s.n_scans = std::numeric_limits<std::int32_t>::min(); }),
                   DecodeError::kBadLength, "volts"});
  cases.push_back({"n_scans beyond the data", with([](RawSpec& s) { s.n_scans = 4; }), DecodeError::kBadLength, "volts"});
  cases.push_back({"n_channels -1", with([](RawSpec& s) { s.n_channels = -1; }), DecodeError::kBadLength,
                   "channel_names"});
  cases.push_back({"n_channels 32767", with([](RawSpec& s) { s.n_channels = 32767; }), DecodeError::kBadLength,
                   "channel_names"});
  cases.push_back({"n_channels 0, n_scans 2^31-1 (a vector per scan, no wire bytes)", with([](RawSpec& s) {
                     s.n_channels = 0;
                     s.names.clear();
                     s.n_scans = std::numeric_limits<std::int32_t>::max();
                     s.volts_written = 0;
                   }),
                   DecodeError::kTooLarge, "volts"});
  cases.push_back({"sensor_id length 0", with([](RawSpec& s) { s.sensor_id_len = 0; }), DecodeError::kBadString,
                   "sensor_id"});
  cases.push_back({"sensor_id length -5", with([](RawSpec& s) { s.sensor_id_len = -5; }), DecodeError::kBadString,
                   "sensor_id"});
  cases.push_back({"sensor_id length 2^31-1", with([](RawSpec& s) { s.sensor_id_len = 0x7fffffff; }),
                   DecodeError::kBadString, "sensor_id"});
  cases.push_back({"sensor_id without NUL", with([](RawSpec& s) { s.sensor_id_len = 2; }), DecodeError::kBadString,
                   "sensor_id"});
  cases.push_back({"sensor_id with a NUL inside", with([](RawSpec& s) { s.sensor_id_len = 3; s.embedded_nul = true; }),
                   DecodeError::kBadString, "sensor_id"});
  cases.push_back({"channel name length 0", with([](RawSpec& s) { s.name0_len = 0; }), DecodeError::kBadString,
                   "channel_names"});
  cases.push_back({"channel name length -1", with([](RawSpec& s) { s.name0_len = -1; }), DecodeError::kBadString,
                   "channel_names"});
  cases.push_back({"channel name length past the end", with([](RawSpec& s) { s.name0_len = 1 << 20; }),
                   DecodeError::kBadString, "channel_names"});
  for (const Case& c : cases) {
    const Bytes b = raw_block(c.spec);
    std::uint64_t alloc = 0;
    const DecodeResult r = decode_counted<pof::raw_block_t>(b, alloc);
    EXPECT_EQ(r.error, c.want) << c.what << ": " << r.describe();
    EXPECT_EQ(r.field, c.field) << c.what;
    EXPECT_LE(alloc, 1024u) << c.what << ": the walk allocates nothing";
    const std::string text = r.describe();
    EXPECT_NE(text.find("raw_block_t"), std::string::npos) << text;
    EXPECT_NE(text.find(c.field), std::string::npos) << text;
    EXPECT_LT(text.size(), 320u);
  }
}

TEST(LcmDecode, HostileStringsOfTheStatusTypesAreErrors) {
  Bytes daq = encode(sample_daq());
  // sensor_id's length sits right after the fingerprint, utime and seq (byte 24).
  for (const std::int32_t len : {0, -1, std::numeric_limits<std::int32_t>::min(), 0x7fffffff}) {
    Bytes b = daq;
    for (int i = 0; i < 4; ++i) b[static_cast<std::size_t>(24 + i)] = static_cast<unsigned char>(static_cast<std::uint32_t>(len) >> (24 - 8 * i));
    std::uint64_t alloc = 0;
    const DecodeResult r = decode_counted<pof::daq_status_t>(b, alloc);
    EXPECT_EQ(r.error, DecodeError::kBadString) << len;
    EXPECT_EQ(r.field, "sensor_id");
    EXPECT_EQ(r.offset, 24u);
    EXPECT_EQ(alloc, 0u);
  }
  Bytes comp = encode(sample_comp());
  comp[24 + 3] = 0;  // sensor_id length 0x00000000 (was 10)
  pof::compensator_status_t c;
  EXPECT_EQ(pof::lcmutil::decode(comp.data(), comp.size(), c).error, DecodeError::kBadString);
}

// The budget admits real traffic: a one-channel block of 100 000 scans (28 heap bytes per 4 wire
// bytes, the largest ratio of our types) decodes, and reusing the message reuses its storage.
TEST(LcmDecode, LargeLegitimateBlocksDecodeAndReuseStorage) {
  pof::raw_block_t big;
  big.sensor_id = "";
  big.n_channels = 1;
  big.channel_names = {"sensor"};
  big.channel_units = {"V"};
  big.n_scans = 100000;
  big.volts.assign(100000, std::vector<float>{1.0f});
  const Bytes b = encode(big);
  pof::raw_block_t m;
  ASSERT_TRUE(pof::lcmutil::decode(b.data(), b.size(), m));
  ASSERT_EQ(m.volts.size(), 100000u);
  g_bytes = 0;
  g_armed = true;
  const bool again = static_cast<bool>(pof::lcmutil::decode(b.data(), b.size(), m));
  g_armed = false;
  EXPECT_TRUE(again);
  EXPECT_EQ(g_bytes.load(), 0u) << "a second decode into the same message allocates nothing";
}

// lcm-gen's decoder skips the inner vectors of volts[n_scans][n_channels] when n_channels is 0, so a
// reused message would keep the previous block's samples; decode() starts fresh in that case.
TEST(LcmDecode, AReusedMessageNeverKeepsThePreviousSamples) {
  pof::raw_block_t m;
  const Bytes three = encode(sample_raw());
  ASSERT_TRUE(pof::lcmutil::decode(three.data(), three.size(), m));
  ASSERT_EQ(m.volts[0].size(), 3u);
  RawSpec none;
  none.n_channels = 0;
  none.names.clear();
  none.n_scans = 5;
  none.volts_written = 0;
  const Bytes zero = raw_block(none);
  ASSERT_TRUE(pof::lcmutil::decode(zero.data(), zero.size(), m));
  ASSERT_EQ(m.volts.size(), 5u);
  for (const auto& scan : m.volts) EXPECT_TRUE(scan.empty());
  EXPECT_TRUE(m.channel_names.empty());
}
