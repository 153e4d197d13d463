// Table-3 statistics: RMSE, eq. (1) hysteresis with and without compensation, max error, fig. 12.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "pof/testing/paper_protocol.hpp"
#include "pof/core/calibration.hpp"
#include "pof/core/statistics.hpp"

using pof::core::CompensatedScan;
using pof::core::CycleStatistics;
using pof::core::Direction;

TEST(Statistics, KnownLoops) {
  CycleStatistics st;
  int closed = 0;
  double t = 0;
  auto sweep = [&](double from, double to, Direction d) {
    const double step = to > from ? 0.5 : -0.5;
    for (double x = from; (step > 0 ? x <= to : x >= to); x += step) {
      CompensatedScan s;
      s.phase = d;
      const double off = d == Direction::kFlexion ? 1 : -1;
      s.angle_deg = x + off;
      s.angle_uncomp_deg = x + 2 * off;
      s.velocity_rad_s = d == Direction::kFlexion ? 0.1 : -0.1;
      closed += st.add(t, s, x) ? 1 : 0;
      t += 0.005;
    }
  };
  sweep(90, 0, Direction::kExtension);  // partial: an extension before any flexion
  for (int c = 0; c < 3; ++c) {
    sweep(0, 90, Direction::kFlexion);
    sweep(90, 0, Direction::kExtension);
  }
  EXPECT_EQ(closed, 2);
  EXPECT_TRUE(st.finish());
  EXPECT_EQ(st.cycles_kept(), 3);
  EXPECT_EQ(st.cycles_dropped(), 1);
  const auto& c = st.last();
  EXPECT_EQ(c.cycle, 3);
  EXPECT_NEAR(c.rmse_comp_deg, 1.0, 1e-12);
  EXPECT_NEAR(c.rmse_uncomp_deg, 2.0, 1e-12);
  EXPECT_NEAR(c.hysteresis_comp_pct, 2.0 / 92 * 100, 1e-9);
  EXPECT_NEAR(c.hysteresis_uncomp_pct, 4.0 / 94 * 100, 1e-9);
  EXPECT_NEAR(c.max_error_deg, 1.0, 1e-12);
  EXPECT_NEAR(c.velocity_rad_s, 100.0 * std::numbers::pi / 180, 1e-9);  // 0.5 deg per 5 ms scan
  const auto o = st.overall();
  EXPECT_EQ(o.cycle, 3);
  EXPECT_NEAR(o.rmse_comp_deg, 1.0, 1e-12);
  EXPECT_EQ(st.profile().count[0], 7 * 10);  // 0..4.5 deg: every moving scan, the dropped partial sweep too
}

// A hold of close_after_hold_s after the extension closes the cycle (a live stream's last cycle
// must not wait for a flexion that never comes); a shorter pause inside the extension does not.
TEST(Statistics, AHoldAfterTheExtensionClosesTheCycle) {
  CycleStatistics st;  // close_after_hold_s = 2 s
  double t = 0;
  int closed = 0;
  double closed_at = -1;
  auto scan = [&](double x, Direction d) {
    CompensatedScan s;
    s.phase = d;
    s.angle_deg = x + (d == Direction::kExtension ? -1 : 1);
    s.angle_uncomp_deg = s.angle_deg;
    if (st.add(t, s, x)) {
      ++closed;
      closed_at = t;
    }
    t += 0.005;
  };
  for (double x = 0; x <= 90; x += 0.5) scan(x, Direction::kFlexion);
  for (double x = 90; x >= 45; x -= 0.5) scan(x, Direction::kExtension);
  for (int k = 0; k < 200; ++k) scan(45, Direction::kHold);  // 1 s pause inside the extension
  for (double x = 45; x >= 0; x -= 0.5) scan(x, Direction::kExtension);
  EXPECT_EQ(closed, 0) << "a 1-s pause must not split the cycle";
  const double hold_start = t;
  for (int k = 0; k < 600; ++k) scan(0, Direction::kHold);  // 3 s hold at the end
  ASSERT_EQ(closed, 1);
  EXPECT_NEAR(closed_at - hold_start, 2.0, 0.006);
  EXPECT_NEAR(st.last().t_end_s, hold_start - 0.005, 1e-9) << "the hold is not part of the cycle";
  EXPECT_NEAR(st.last().rmse_comp_deg, 1.0, 1e-12);
  EXPECT_FALSE(st.finish()) << "nothing left open";
  EXPECT_EQ(st.cycles_kept(), 1);
}

// Compensation with a calibration fitted on one recording, applied to validation cycles like
// table 3 (10-80 deg, 3 cycles at 0.05 ... 0.26 rad/s): less error and less hysteresis.
TEST(Statistics, CompensationReducesErrorAndHysteresisOnValidationCycles) {
  const auto cal_rec = pof::testing::paper_recording();
  const auto r = pof::core::calibrate(cal_rec.t_s, cal_rec.sensor_v, cal_rec.reference_v, cal_rec.angle_ref_deg);
  pof::testing::ProtocolSettings p;
  p.quasi_static = false;
  p.angle_lo = 10;
  p.angle_hi = 80;
  p.cycles_per_velocity = 3;
  p.seed = 99;
  for (double w : {0.05, 0.10, 0.16, 0.21, 0.26}) {
    p.velocities_rad_s = {w};
    const auto g = pof::testing::paper_recording(p);
    pof::core::OnlineCompensator comp(r.cal);
    CycleStatistics st;
    for (Eigen::Index i = 0; i < g.size(); ++i) st.add(g.t_s(i), comp.step(g.sensor_v(i), g.reference_v(i)), g.angle_ref_deg(i));
    st.finish();
    const auto o = st.overall();
    std::printf("w=%.2f cycles=%d RMSE %.2f/%.2f deg  H %.2f/%.2f %%  max %.2f deg (comp/uncomp)\n", w, o.cycle,
                o.rmse_comp_deg, o.rmse_uncomp_deg, o.hysteresis_comp_pct, o.hysteresis_uncomp_pct, o.max_error_deg);
    EXPECT_EQ(o.cycle, 3);
    // The phases lag the movement by ~0.25 s, so each sweep includes part of the stop: a few % low.
    EXPECT_NEAR(o.velocity_rad_s, w, 0.07 * w);
    EXPECT_LT(o.rmse_comp_deg, o.rmse_uncomp_deg);
    EXPECT_LT(o.hysteresis_comp_pct, 0.5 * o.hysteresis_uncomp_pct);
  }
}
