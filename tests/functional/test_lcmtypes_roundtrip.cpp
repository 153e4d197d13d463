// Every message type of package `pof` survives encode -> memq:// -> decode unchanged.
// memq:// is LCM's in-process transport: a real publish/subscribe, no network, no mocking.
#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "pof/angle_t.hpp"
#include "pof/compensator_status_t.hpp"
#include "pof/cycle_stats_t.hpp"
#include "pof/daq_status_t.hpp"
#include "pof/bus/receiver.hpp"
#include "pof/raw_block_t.hpp"

namespace {

// Publishes `msg` on `channel` over memq:// and returns what a subscriber decoded (through
// pof::bus::Receiver and its bounded decoder, the way every pofkit process receives).
template <typename Msg>
std::optional<Msg> round_trip(const std::string& channel, const Msg& msg) {
  lcm::LCM lc("memq://");
  EXPECT_TRUE(lc.good());
  std::optional<Msg> got;
  {
    pof::bus::Receiver rx(lc, "memq://");
    rx.subscribe<Msg>(channel, [&got](const Msg& m, const pof::bus::Delivery&) { got = m; });
    EXPECT_EQ(lc.publish(channel, &msg), 0);
    EXPECT_EQ(rx.handle(1000), 1);  // memq delivers synchronously into the queue
    EXPECT_EQ(rx.stats().decode_errors, 0u);
  }
  return got;
}

// Encodes into a byte buffer and checks the size the type reports (catches dimension mistakes).
template <typename Msg>
void expect_encoded_size_consistent(const Msg& msg) {
  const int n = msg.getEncodedSize();
  ASSERT_GT(n, 8);
  std::string buf(static_cast<size_t>(n), '\0');
  EXPECT_EQ(msg.encode(buf.data(), 0, n), n);
  Msg back;
  EXPECT_EQ(back.decode(buf.data(), 0, n), n);
}

}  // namespace

TEST(LcmTypesRoundTrip, RawBlock) {
  pof::raw_block_t m;
  m.utime = 1'763'700'000'123'456;
  m.publish_utime = m.utime + 1234;
  m.seq = 42;
  m.first_scan = 9'000'000'001;
  m.scan_rate_hz = 1000.0;
  m.sensor_id = "LEFT_KNEE";
  m.n_channels = 3;
  m.channel_names = {"sensor", "reference", "pot"};
  m.channel_units = {"V", "V", "V"};
  m.n_scans = 5;
  m.volts.assign(5, std::vector<float>(3));
  for (int k = 0; k < 5; ++k)
    for (int c = 0; c < 3; ++c) m.volts[size_t(k)][size_t(c)] = 0.25f * float(k) - 1.5f * float(c);
  // lcm-gen emits constants as unnamed enums; C++20 deprecates mixing them, hence the casts.
  m.flags = int32_t{pof::raw_block_t::FLAG_GAP} | int32_t{pof::raw_block_t::FLAG_OVER_RANGE};
  expect_encoded_size_consistent(m);

  const auto got = round_trip("POF_RAW", m);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->utime, m.utime);
  EXPECT_EQ(got->publish_utime, m.publish_utime);
  EXPECT_EQ(got->seq, m.seq);
  EXPECT_EQ(got->first_scan, m.first_scan);
  EXPECT_EQ(got->scan_rate_hz, m.scan_rate_hz);
  EXPECT_EQ(got->sensor_id, m.sensor_id);
  EXPECT_EQ(got->channel_names, m.channel_names);
  EXPECT_EQ(got->channel_units, m.channel_units);
  EXPECT_EQ(got->n_scans, m.n_scans);
  EXPECT_EQ(got->volts, m.volts);
  EXPECT_EQ(got->flags, m.flags);
}

TEST(LcmTypesRoundTrip, EmptyRawBlock) {
  pof::raw_block_t m{};
  m.n_channels = 0;
  m.n_scans = 0;
  const auto got = round_trip("POF_RAW", m);
  ASSERT_TRUE(got);
  EXPECT_TRUE(got->volts.empty());
}

TEST(LcmTypesRoundTrip, Angle) {
  pof::angle_t m;
  m.utime = 1'763'700'000'000'005;
  m.publish_utime = m.utime + 300;
  m.seq = 7;
  m.scan_index = 123456;
  m.angle_deg = 47.25f;
  m.angle_uncomp_deg = 48.5f;
  m.angle_ref_deg = std::nanf("");  // no reference channel: NaN must survive the wire
  m.velocity_rad_s = -0.1047f;
  m.phase = pof::angle_t::PHASE_EXTENSION;
  m.quality = int32_t{pof::angle_t::QUALITY_GAP} | int32_t{pof::angle_t::QUALITY_SETTLING};
  const auto got = round_trip("POF_ANGLE", m);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->utime, m.utime);
  EXPECT_EQ(got->publish_utime, m.publish_utime);
  EXPECT_EQ(got->seq, m.seq);
  EXPECT_EQ(got->scan_index, m.scan_index);
  EXPECT_EQ(got->angle_deg, m.angle_deg);
  EXPECT_EQ(got->angle_uncomp_deg, m.angle_uncomp_deg);
  EXPECT_TRUE(std::isnan(got->angle_ref_deg));
  EXPECT_EQ(got->velocity_rad_s, m.velocity_rad_s);
  EXPECT_EQ(got->phase, m.phase);
  EXPECT_EQ(got->quality, m.quality);
}

TEST(LcmTypesRoundTrip, CycleStats) {
  pof::cycle_stats_t m;
  m.utime = 1'763'700'010'000'000;
  m.seq = 3;
  m.cycle = 4;
  m.start_utime = m.utime - 30'000'000;
  m.end_utime = m.utime;
  m.velocity_rad_s = 0.21f;
  m.rmse_comp_deg = 1.58f;
  m.rmse_uncomp_deg = 1.92f;
  m.hysteresis_comp_pct = 0.03f;
  m.hysteresis_uncomp_pct = 5.10f;
  m.max_error_deg = 2.4f;
  m.n_samples = 6000;
  const auto got = round_trip("POF_STATS", m);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->utime, m.utime);
  EXPECT_EQ(got->seq, m.seq);
  EXPECT_EQ(got->cycle, m.cycle);
  EXPECT_EQ(got->start_utime, m.start_utime);
  EXPECT_EQ(got->end_utime, m.end_utime);
  EXPECT_EQ(got->velocity_rad_s, m.velocity_rad_s);
  EXPECT_EQ(got->rmse_comp_deg, m.rmse_comp_deg);
  EXPECT_EQ(got->rmse_uncomp_deg, m.rmse_uncomp_deg);
  EXPECT_EQ(got->hysteresis_comp_pct, m.hysteresis_comp_pct);
  EXPECT_EQ(got->hysteresis_uncomp_pct, m.hysteresis_uncomp_pct);
  EXPECT_EQ(got->max_error_deg, m.max_error_deg);
  EXPECT_EQ(got->n_samples, m.n_samples);
}

TEST(LcmTypesRoundTrip, DaqStatus) {
  pof::daq_status_t m;
  m.utime = 1'763'700'020'000'000;
  m.seq = 11;
  m.sensor_id = "RIGHT_KNEE";
  m.device_kind = "usb6008";
  m.vendor_id = 0x3923;
  m.product_id = 0x717a;
  m.serial = "01A2B3C4";
  m.state = pof::daq_status_t::STATE_DISCONNECTED;
  m.state_text = "USB device 001/002 removed (LIBUSB_ERROR_NO_DEVICE)";
  m.scan_rate_hz = 1000.0;
  m.n_channels = 3;
  m.scans = 1'000'000;
  m.blocks = 50'000;
  m.dropped_scans = 17;
  m.usb_errors = 2;
  m.overruns = 1;
  m.reconnects = 1;
  m.publish_failures = 3;
  const auto got = round_trip("POF_DAQ_STATUS", m);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->utime, m.utime);
  EXPECT_EQ(got->seq, m.seq);
  EXPECT_EQ(got->sensor_id, m.sensor_id);
  EXPECT_EQ(got->device_kind, m.device_kind);
  EXPECT_EQ(got->vendor_id, m.vendor_id);
  EXPECT_EQ(got->product_id, m.product_id);
  EXPECT_EQ(got->serial, m.serial);
  EXPECT_EQ(got->state, m.state);
  EXPECT_EQ(got->state_text, m.state_text);
  EXPECT_EQ(got->scan_rate_hz, m.scan_rate_hz);
  EXPECT_EQ(got->n_channels, m.n_channels);
  EXPECT_EQ(got->scans, m.scans);
  EXPECT_EQ(got->blocks, m.blocks);
  EXPECT_EQ(got->dropped_scans, m.dropped_scans);
  EXPECT_EQ(got->usb_errors, m.usb_errors);
  EXPECT_EQ(got->overruns, m.overruns);
  EXPECT_EQ(got->reconnects, m.reconnects);
  EXPECT_EQ(got->publish_failures, 3);
}

TEST(LcmTypesRoundTrip, CompensatorStatus) {
  pof::compensator_status_t m{};
  m.utime = 1'763'700'030'000'000;
  m.seq = 12;
  m.sensor_id = "LEFT_KNEE";
  m.calibration_path = "/etc/pof/calibration/left_knee.toml";
  m.calibration_sensor_id = "LK";
  m.calibration_date = "2026-11-21T00:00:00Z";
  m.blocks = 1000;
  m.lost_blocks = std::numeric_limits<std::int64_t>::max();  // saturated
  m.last_error = "";
  m.decode_errors = 5;
  m.malformed_datagrams = 1001;
  m.duplicate_blocks = 2;
  m.publish_failures = 4;
  m.authenticated = true;
  m.auth_unsigned = 6;
  m.auth_bad_mac = 7;
  m.auth_stale = 8;
  m.auth_replayed = 9;
  const auto got = round_trip("POF_COMPENSATOR_STATUS", m);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->calibration_path, m.calibration_path);
  EXPECT_EQ(got->lost_blocks, m.lost_blocks);
  EXPECT_EQ(got->decode_errors, 5);
  EXPECT_EQ(got->malformed_datagrams, 1001);
  EXPECT_EQ(got->duplicate_blocks, 2);
  EXPECT_EQ(got->publish_failures, 4);
  EXPECT_TRUE(got->authenticated);
  EXPECT_EQ(got->auth_unsigned, 6);
  EXPECT_EQ(got->auth_bad_mac, 7);
  EXPECT_EQ(got->auth_stale, 8);
  EXPECT_EQ(got->auth_replayed, 9);
}

// A message of one type sent on a channel subscribed with another type must not decode: the
// 8-byte fingerprint at the front of every message guards against it (docs/lcm.md).
TEST(LcmTypesRoundTrip, FingerprintRejectsWrongType) {
  pof::angle_t a{};
  const int n = a.getEncodedSize();
  std::string buf(static_cast<size_t>(n), '\0');
  ASSERT_EQ(a.encode(buf.data(), 0, n), n);
  pof::cycle_stats_t s;
  EXPECT_LT(s.decode(buf.data(), 0, n), 0);
}
