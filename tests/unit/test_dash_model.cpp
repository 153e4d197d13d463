// The model behind `pof dash` (tools/dash/include/pof/dash/model.hpp): thinning, cursors, bounds.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "lcm_test.hpp"
#include "pof/dash/model.hpp"

using pof::dash::Cursor;
using pof::dash::Model;
using pof::dash::ModelSettings;

namespace {

using pof::test::encode;

void feed(Model& m, const std::string& ch, const std::vector<unsigned char>& b, int64_t t) {
  m.on_message(ch, b.data(), b.size(), t);
}

constexpr int64_t kT0 = 1'800'000'000'000'000;

// n angles at `rate` Hz from scan time t0 (received at their scan time), angle = index.
int64_t feed_angles(Model& m, const std::string& ch, int n, double rate, int64_t t0, int64_t seq0 = 0,
                    int32_t quality_every = 0) {
  pof::angle_t a{};
  int64_t t = t0;
  for (int i = 0; i < n; ++i) {
    t = t0 + static_cast<int64_t>(std::llround(i * 1e6 / rate));
    a.utime = t;
    a.seq = seq0 + i;
    a.angle_deg = static_cast<float>(seq0 + i);
    a.angle_ref_deg = 1.0f;
    a.quality = quality_every > 0 && i % quality_every == quality_every - 1 ? 8 : 0;
    feed(m, ch, encode(a), t);
  }
  return t;
}

}  // namespace

TEST(DashModel, ThinsToTheDisplayRateKeepingEveryFlag) {
  ModelSettings s;
  s.display_hz = 100;
  Model m(s);
  // 1 s at 3,333 angles/s, every 500th flagged: 100 display points, the bucket's last angle each,
  // and a flagged angle's bit in its bucket's point.
  const int64_t t_end = feed_angles(m, "POF_ANGLE_LEFT_KNEE", 3333, 3333, kT0, 0, 500);
  m.tick(t_end + 20'000);
  Cursor c;
  const auto f = m.frame(c, t_end + 20'000);
  ASSERT_EQ(f["sensors"].size(), 1u);
  const auto& sf = f["sensors"][0];
  EXPECT_EQ(sf["id"], "LEFT_KNEE");
  EXPECT_EQ(sf["angles"], 3333);
  EXPECT_EQ(sf["angles_flagged"], 6);
  EXPECT_EQ(sf["angles_missing"], 0);
  const auto& p = sf["points"];
  EXPECT_NEAR(static_cast<double>(p["t"].size()), 100.0, 1.0);
  int flagged_points = 0;
  for (const auto& q : p["quality"]) flagged_points += q.get<int>() != 0;
  EXPECT_EQ(flagged_points, 6);
  EXPECT_EQ(p["angle"].back().get<double>(), 3332.0);  // the last angle is the last point
  EXPECT_TRUE(sf["reset"].get<bool>());
}

TEST(DashModel, ACursorGetsOnlyWhatItHasNotSeen) {
  Model m;
  int64_t t = feed_angles(m, "POF_ANGLE", 100, 100, kT0);
  m.tick(t + 20'000);
  Cursor c;
  const auto first = m.frame(c, t);
  const std::size_t n1 = first["sensors"][0]["points"]["t"].size();
  EXPECT_EQ(n1, 100u);
  EXPECT_EQ(first["sensors"][0]["id"], "");  // an unsuffixed channel is the sensor ""
  const auto nothing = m.frame(c, t);
  EXPECT_EQ(nothing["sensors"][0]["points"]["t"].size(), 0u);
  EXPECT_FALSE(nothing["sensors"][0]["reset"].get<bool>());
  t = feed_angles(m, "POF_ANGLE", 50, 100, t + 10'000, 100);
  m.tick(t + 20'000);
  const auto more = m.frame(c, t);
  EXPECT_EQ(more["sensors"][0]["points"]["t"].size(), 50u);
  EXPECT_EQ(more["sensors"][0]["points"]["angle"][0].get<double>(), 100.0);
}

TEST(DashModel, ACursorThatFellOutOfTheWindowGetsItWhole) {
  ModelSettings s;
  s.window_s = 10;
  s.display_hz = 10;
  Model m(s);
  Cursor c;
  int64_t t = feed_angles(m, "POF_ANGLE", 10, 10, kT0);
  m.tick(t + 200'000);
  (void)m.frame(c, t);
  t = feed_angles(m, "POF_ANGLE", 300, 10, t + 100'000, 10);  // 30 s: three windows
  m.tick(t + 200'000);
  const auto f = m.frame(c, t);
  EXPECT_TRUE(f["sensors"][0]["reset"].get<bool>());
  EXPECT_EQ(f["sensors"][0]["points"]["t"].size(), m.ring_capacity());
  EXPECT_EQ(f["sensors"][0]["points"]["angle"].back().get<double>(), 309.0);
}

TEST(DashModel, NanIsNullAndGapsAreCounted) {
  Model m;
  pof::angle_t a{};
  a.utime = kT0;
  a.seq = 0;
  a.angle_deg = std::nanf("");
  feed(m, "POF_ANGLE", encode(a), kT0);
  a.utime += 20'000;
  a.seq = 5;  // 4 missing
  a.angle_deg = 1.0f;
  feed(m, "POF_ANGLE", encode(a), a.utime);
  m.tick(a.utime + 20'000);
  Cursor c;
  const auto f = m.frame(c, a.utime + 20'000);
  const auto& sf = f["sensors"][0];
  EXPECT_EQ(sf["angles_missing"], 4);
  EXPECT_TRUE(sf["points"]["angle"][0].is_null());
  EXPECT_NO_THROW((void)f.dump());  // valid JSON: no NaN literal
}

TEST(DashModel, CyclesStatusAndDecodeErrors) {
  Model m;
  Cursor c;
  for (int i = 1; i <= 70; ++i) {
    pof::cycle_stats_t s{};
    s.cycle = i;
    s.rmse_comp_deg = 0.01f * static_cast<float>(i);
    feed(m, "POF_STATS_RIGHT_KNEE", encode(s), kT0 + i);
  }
  pof::daq_status_t d{};
  d.state = pof::daq_status_t::STATE_STREAMING;
  d.dropped_scans = 3;
  feed(m, "POF_DAQ_STATUS_RIGHT_KNEE", encode(d), kT0);
  const unsigned char junk[] = {1, 2, 3};
  m.on_message("POF_COMPENSATOR_STATUS_RIGHT_KNEE", junk, sizeof junk, kT0);
  const auto f = m.frame(c, kT0 + 1'500'000);
  const auto& sf = f["sensors"][0];
  EXPECT_EQ(sf["cycles_total"], 70);
  ASSERT_EQ(sf["cycles"].size(), ModelSettings{}.cycles_kept);  // the last ones kept
  EXPECT_EQ(sf["cycles"].back()["cycle"], 70);
  EXPECT_EQ(sf["daq"]["state_name"], "STREAMING");
  EXPECT_EQ(sf["daq"]["dropped_scans"], 3);
  EXPECT_NEAR(sf["daq_age_s"].get<double>(), 1.5, 1e-9);
  EXPECT_TRUE(sf["compensator"].is_null());
  EXPECT_EQ(sf["decode_errors"], 1);
  EXPECT_EQ(m.frame(c, kT0)["sensors"][0]["cycles"].size(), 0u);  // seen: not sent again
}

TEST(DashModel, StateIsBoundedWhateverTheChannelNames) {
  Model m;
  pof::angle_t a{};
  for (int i = 0; i < 5000; ++i) {
    a.utime = kT0 + i;
    feed(m, "POF_ANGLE_S" + std::to_string(i), encode(a), kT0 + i);
  }
  feed(m, "POF_ANGLE_lower_case", encode(a), kT0);  // not a sensor id
  feed(m, "POF_RAW_S1", encode(a), kT0);             // raw blocks are not the dashboard's
  feed(m, "FOREIGN", encode(a), kT0);
  EXPECT_EQ(m.sensors(), Model::kMaxSensors);
  EXPECT_EQ(m.ignored_sensors(), 5000 - Model::kMaxSensors + 1);
}
