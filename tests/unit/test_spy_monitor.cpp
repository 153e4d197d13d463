// The model and renderer of `pof spy` (tools/spy/include/pof/spy/monitor.hpp).
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "pof/bus/auth.hpp"
#include "pof/spy/monitor.hpp"

using pof::spy::Monitor;

namespace {

template <class T>
std::vector<unsigned char> enc(const T& m) {
  std::vector<unsigned char> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

void feed(Monitor& m, const std::string& ch, const std::vector<unsigned char>& b, int64_t t) {
  m.on_message(ch, b.data(), b.size(), t);
}

}  // namespace

TEST(SpyMonitor, RatesCountsAndGaps) {
  Monitor m;
  pof::angle_t a{};
  int64_t t = 1'000'000'000;
  m.tick(t);
  for (int64_t i = 0; i < 100; ++i) {
    a.seq = i < 50 ? i : i + 3;  // one gap of 3 messages
    feed(m, "POF_ANGLE", enc(a), t);
    t += 10'000;  // 100 Hz
    if (i % 25 == 24) m.tick(t);
  }
  const auto& c = m.channels().at("POF_ANGLE");
  EXPECT_EQ(c.count, 100u);
  EXPECT_EQ(c.seq.gaps, 1u);
  EXPECT_EQ(c.seq.missing, 3u);
  EXPECT_NEAR(c.rate_hz, 100.0, 1.0);
  EXPECT_EQ(c.type, pof::bus::MessageType::kAngle);
}

TEST(SpyMonitor, RendersDecodedValuesOfOurTypesAndFingerprintsOfOthers) {
  Monitor m;
  pof::raw_block_t r{};
  r.seq = 0;
  r.sensor_id = "LEFT_KNEE";
  r.scan_rate_hz = 1000;
  r.n_channels = 3;
  r.channel_names = {"sensor", "reference", "pot"};
  r.channel_units = {"V", "V", "V"};
  r.n_scans = 1;
  r.volts = {{4.125f, 4.35f, 1.5f}};
  r.flags = pof::raw_block_t::FLAG_SIMULATED;
  feed(m, "POF_RAW_LEFT_KNEE", enc(r), 1);
  pof::angle_t a{};
  a.angle_deg = 30.5f;
  a.angle_ref_deg = 30.0f;
  a.phase = pof::angle_t::PHASE_FLEXION;
  a.quality = int32_t{pof::angle_t::QUALITY_GAP} | int32_t{pof::angle_t::QUALITY_SETTLING};
  feed(m, "POF_ANGLE_LEFT_KNEE", enc(a), 1);
  pof::cycle_stats_t s{};
  s.cycle = 7;
  s.rmse_comp_deg = 1.25f;
  feed(m, "POF_STATS_LEFT_KNEE", enc(s), 1);
  pof::daq_status_t d{};
  d.state = pof::daq_status_t::STATE_DISCONNECTED;
  d.state_text = "device unplugged";
  d.device_kind = "usb6008";
  d.reconnects = 2;
  d.publish_failures = 3;
  feed(m, "POF_DAQ_STATUS_LEFT_KNEE", enc(d), 1);
  pof::compensator_status_t cs{};
  cs.sensor_id = "LEFT_KNEE";
  cs.calibration_path = "/etc/pof/cal.toml";
  cs.lost_blocks = 4;
  cs.lost_scans = 200;
  cs.rejected_blocks = 1;
  cs.reload_failures = 1;
  cs.last_error = "cal.toml: key 'model.c9': expected a number";
  cs.publish_failures = 5;
  feed(m, "POF_COMPENSATOR_STATUS_LEFT_KNEE", enc(cs), 1);
  const std::vector<unsigned char> foreign{1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  feed(m, "OTHER", foreign, 1);

  pof::spy::RenderOptions o;
  o.ansi = false;
  o.now_utime = 2;
  const std::string text = pof::spy::render(m, o);
  EXPECT_NE(text.find("sensor 4.1250 V"), std::string::npos) << text;
  EXPECT_NE(text.find("SIMULATED"), std::string::npos);
  EXPECT_NE(text.find("30.50 deg"), std::string::npos);
  EXPECT_NE(text.find("err 0.50 deg"), std::string::npos);
  EXPECT_NE(text.find("FLEXION"), std::string::npos);
  EXPECT_NE(text.find("GAP|SETTLING"), std::string::npos);
  EXPECT_NE(text.find("DISCONNECTED (device unplugged)"), std::string::npos);
  EXPECT_NE(text.find("reconnects 2"), std::string::npos);
  EXPECT_NE(text.find("reconnects 2  publish_failures 3"), std::string::npos) << text;  // both daemons' refused publishes
  EXPECT_NE(text.find("publish_failures 5"), std::string::npos) << text;
  EXPECT_NE(text.find("fp:0102030405060708"), std::string::npos);
  // The compensator's drops and its failed reload are on screen, not only its message count.
  EXPECT_NE(text.find("calibration /etc/pof/cal.toml"), std::string::npos) << text;
  EXPECT_NE(text.find("lost_blocks 4  lost_scans 200  rejected_blocks 1"), std::string::npos) << text;
  EXPECT_NE(text.find("reload failures 1  last error: cal.toml: key 'model.c9'"), std::string::npos) << text;
  EXPECT_NE(text.find("      7 "), std::string::npos);  // the cycle row
  EXPECT_EQ(text.find("\x1b["), std::string::npos);      // plain text for --once
}

TEST(SpyMonitor, CountsUndecodableMessagesOfOurTypes) {
  Monitor m;
  pof::raw_block_t r{};
  r.n_channels = 1;
  r.channel_names = {"sensor"};
  r.channel_units = {"V"};
  r.n_scans = 1;
  r.volts = {{1.0f}};
  auto b = enc(r);
  b.resize(b.size() - 3);  // truncated: fingerprint matches, decode fails
  feed(m, "POF_RAW", b, 1);
  EXPECT_EQ(m.channels().at("POF_RAW").decode_errors, 1u);
  EXPECT_FALSE(m.channels().at("POF_RAW").raw.has_value());
}

TEST(SpyMonitor, QualityAndPhaseNames) {
  EXPECT_EQ(pof::spy::quality_names(0), "OK");
  EXPECT_EQ(pof::spy::quality_names(1 | 4 | 256), "REFERENCE_LOST|INVALID_INPUT|0x100");
  EXPECT_EQ(pof::spy::phase_name(2), "EXTENSION");
  EXPECT_EQ(pof::spy::daq_state_name(9), "9");
}

// Authenticated mode: without a key the spy shows a signed message from the LCM message in front of
// its trailer, marked SIGNED, NOT VERIFIED (not a decode error); with a key the receiver verified
// it and the header shows what the verifier dropped; the compensator's drops are on screen.
TEST(SpyMonitor, SignedMessagesAndAuthenticationCounters) {
  Monitor m;
  pof::angle_t a{};
  a.seq = 3;
  a.angle_deg = 42.5f;
  std::vector<unsigned char> b = enc(a);
  const std::size_t n = b.size();
  b.resize(n + pof::bus::auth::kTrailerBytes);
  std::vector<unsigned char> kb(pof::bus::auth::Key::kBytes, 9);
  pof::bus::auth::Signer signer(std::make_shared<const pof::bus::auth::Key>(kb.data(), kb.size()), 1);
  ASSERT_TRUE(signer.sign("POF_ANGLE", b.data(), n, 1'000));
  feed(m, "POF_ANGLE", b, 1);
  const auto& c = m.channels().at("POF_ANGLE");
  EXPECT_EQ(c.decode_errors, 0u);
  EXPECT_EQ(c.unverified, 1u);
  ASSERT_TRUE(c.angle);
  EXPECT_EQ(c.angle->angle_deg, 42.5f);
  pof::compensator_status_t cs{};
  cs.authenticated = true;
  cs.auth_unsigned = 11;
  cs.auth_bad_mac = 12;
  cs.auth_stale = 13;
  cs.auth_replayed = 14;
  feed(m, "POF_COMPENSATOR_STATUS", enc(cs), 1);

  pof::spy::RenderOptions o;
  o.ansi = false;
  std::string text = pof::spy::render(m, o);
  EXPECT_NE(text.find("SIGNED, NOT VERIFIED 1"), std::string::npos) << text;
  EXPECT_NE(text.find("42.50 deg"), std::string::npos) << text;
  EXPECT_NE(text.find("auth_unsigned 11  auth_bad_mac 12  auth_stale 13  auth_replayed 14"), std::string::npos) << text;
  EXPECT_EQ(text.find("authenticated (key"), std::string::npos) << text;  // this spy verifies nothing
  o.authenticated = true;
  o.key_id = "1a2b3c4d";
  o.auth_unsigned = 1;
  o.auth_bad_mac = 2;
  o.auth_stale = 3;
  o.auth_replayed = 4;
  text = pof::spy::render(m, o);
  EXPECT_NE(text.find("authenticated (key 1a2b3c4d): dropped unsigned 1  bad_mac 2  stale 3  replayed 4"), std::string::npos)
      << text;
}

// Any local process can publish on any name: the spy keeps a row for at most kMaxTrackedChannels
// names (POF_* names a reserve beyond it) and counts messages on the rest together, so a flood of
// distinct names neither grows it without bound nor hides pofkit's own channels.
TEST(SpyMonitor, DistinctChannelNamesAreBoundedAndTheRestCountedTogether) {
  using pof::recorder::kMaxTrackedChannels;
  using pof::recorder::kPofChannelReserve;
  Monitor m;
  pof::angle_t a{};
  const auto b = enc(a);
  constexpr std::size_t kFlood = 20000;
  for (std::size_t i = 0; i < kFlood; ++i) feed(m, "FLOOD_" + std::to_string(i), b, 1);
  EXPECT_EQ(m.channels().size(), kMaxTrackedChannels);
  EXPECT_EQ(m.other_channels().events, kFlood - kMaxTrackedChannels);
  EXPECT_EQ(m.other_channels().bytes, (kFlood - kMaxTrackedChannels) * b.size());
  EXPECT_EQ(m.other_channels().examples.size(), pof::recorder::kOtherExamples);
  EXPECT_EQ(m.other_channels().examples.front(), "FLOOD_1024");
  EXPECT_EQ(m.total_messages(), kFlood);
  // pofkit's own channels still get their rows after the flood, and a tracked name keeps its row.
  for (int i = 0; i < 3; ++i) feed(m, "POF_ANGLE_LEFT_KNEE", b, 2);
  feed(m, "FLOOD_0", b, 2);
  ASSERT_EQ(m.channels().count("POF_ANGLE_LEFT_KNEE"), 1U);
  EXPECT_EQ(m.channels().at("POF_ANGLE_LEFT_KNEE").count, 3U);
  EXPECT_EQ(m.channels().at("FLOOD_0").count, 2U);
  // ... but a flood of POF_* names is bounded too.
  for (std::size_t i = 0; i < kFlood; ++i) feed(m, "POF_FLOOD_" + std::to_string(i), b, 3);
  EXPECT_EQ(m.channels().size(), kMaxTrackedChannels + kPofChannelReserve);
  EXPECT_EQ(m.other_channels().events, 2 * kFlood - kMaxTrackedChannels - (kPofChannelReserve - 1));
  m.tick(4);
  pof::spy::RenderOptions o;
  o.ansi = false;
  const std::string text = pof::spy::render(m, o);
  EXPECT_NE(text.find("(other channels)"), std::string::npos);
  EXPECT_NE(text.find("not tracked: more than 1024 channels (e.g. FLOOD_1024, FLOOD_1025"), std::string::npos);
}
