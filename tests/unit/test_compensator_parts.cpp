// The online compensator's parts, each alone: the velocity window (running sums against a direct
// fit, the edits the step detector makes), the direction detector (dead band, reversal window,
// a step's decision), the step detector (a predicted step found and taken out, none on a smooth
// movement) and the [gap] term chains (no terms: nothing; a creep: the quiet angle takes it off).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "pof/core/compensator.hpp"
#include "pof/core/direction_detector.hpp"
#include "pof/core/step_detector.hpp"
#include "pof/core/term_chains.hpp"
#include "pof/core/units.hpp"
#include "pof/core/velocity_window.hpp"

using pof::core::CompensatorSettings;
using pof::core::Direction;
using pof::core::DirectionDetector;
using pof::core::StepDetector;
using pof::core::TermChains;
using pof::core::VelocityWindow;

namespace {

// Least-squares slope of y over 0..n-1, computed directly.
double direct_slope(const std::vector<double>& y) {
  const double n = static_cast<double>(y.size()), jbar = (n - 1) / 2;
  double ybar = 0, sxy = 0, sxx = 0;
  for (double v : y) ybar += v;
  ybar /= n;
  for (std::size_t j = 0; j < y.size(); ++j) {
    sxy += (static_cast<double>(j) - jbar) * (y[j] - ybar);
    sxx += (static_cast<double>(j) - jbar) * (static_cast<double>(j) - jbar);
  }
  return sxy / sxx;
}

// Feeds `scans` angles of a constant velocity w [rad/s] at 200 Hz to a window, from angle a0 [deg].
double ramp(VelocityWindow& win, double a0, double w_rad_s, int scans) {
  double a = a0;
  for (int i = 0; i < scans; ++i) {
    a += w_rad_s * pof::core::kDegPerRad / 200.0;
    win.push(a);
  }
  return a;
}

}  // namespace

TEST(VelocityWindow, RunningSlopeEqualsTheDirectFitOfTheNewestAngles) {
  VelocityWindow win(50);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0, 0.3);
  std::vector<double> all;
  for (int i = 0; i < 10'000; ++i) {  // past the 4096-scan refresh of the running sums
    const double y = 0.01 * i + noise(rng);
    all.push_back(y);
    const double s = win.push(y);
    if (i == 0) {
      EXPECT_TRUE(std::isnan(s));
      continue;
    }
    const std::vector<double> newest(all.end() - std::min<std::ptrdiff_t>(50, std::ssize(all)), all.end());
    ASSERT_NEAR(s, direct_slope(newest), 1e-9) << "scan " << i;
  }
  EXPECT_TRUE(win.full());
  const std::vector<double> last10(all.end() - 10, all.end());
  EXPECT_NEAR(win.recent_slope(10), direct_slope(last10), 1e-12);
  EXPECT_TRUE(std::isnan(win.recent_slope(51)));
}

TEST(VelocityWindow, AnEditedAngleCountsOnceRefreshed) {
  VelocityWindow win(10);
  for (int i = 0; i < 10; ++i) win.push(i);
  std::vector<double> x(4);
  win.copy_newest(x.data(), 4);
  EXPECT_EQ(x, (std::vector<double>{9, 8, 7, 6}));
  win.back(0) -= 9;  // the newest angle, now 0
  win.refresh();
  EXPECT_NEAR(win.slope(), direct_slope({0, 1, 2, 3, 4, 5, 6, 7, 8, 0}), 1e-12);
  win.clear();
  EXPECT_EQ(win.count(), 0);
  EXPECT_TRUE(std::isnan(win.slope()));
}

TEST(DirectionDetector, DeadBandHoldsBetweenTheThresholds) {
  CompensatorSettings s;  // move 0.010, hold 0.006 rad/s
  DirectionDetector d(s, 0);
  VelocityWindow win(100);
  ramp(win, 0, 0.0, 100);
  ASSERT_TRUE(win.full());
  EXPECT_EQ(d.update(win, 0.008, Direction::kHold, 0), Direction::kHold);    // inside the band: no start
  EXPECT_EQ(d.update(win, 0.011, Direction::kHold, 0), Direction::kFlexion);
  EXPECT_EQ(d.update(win, 0.007, Direction::kFlexion, 0), Direction::kFlexion);  // inside: keeps moving
  EXPECT_EQ(d.update(win, 0.005, Direction::kFlexion, 0), Direction::kHold);
  EXPECT_EQ(d.update(win, -0.02, Direction::kHold, 0), Direction::kExtension);
  EXPECT_EQ(d.update(win, 0.02, Direction::kExtension, 0), Direction::kFlexion);  // a direct reversal
}

TEST(DirectionDetector, AWindowNotYetFullIsAHold) {
  DirectionDetector d(CompensatorSettings{}, 0);
  VelocityWindow win(100);
  ramp(win, 0, 0.5, 50);
  EXPECT_EQ(d.update(win, 0.5, Direction::kHold, 0), Direction::kHold);
}

TEST(DirectionDetector, TheReversalWindowFlipsBeforeTheLongOne) {
  CompensatorSettings s;
  s.reversal_window_s = 0.1;
  DirectionDetector d(s, 20);
  VelocityWindow win(100);
  double a = ramp(win, 10, 0.3, 100);
  EXPECT_EQ(d.update(win, 0.3, Direction::kHold, 0), Direction::kFlexion);
  a = ramp(win, a, -0.3, 20);  // the newest 20 scans turned; the long window still reads flexion
  EXPECT_EQ(d.update(win, 0.05, Direction::kFlexion, 0), Direction::kExtension);
  DirectionDetector slow(CompensatorSettings{}, 0);
  EXPECT_EQ(slow.update(win, 0.3, Direction::kHold, 0), Direction::kFlexion);
  EXPECT_EQ(slow.update(win, 0.05, Direction::kFlexion, 0), Direction::kFlexion);
}

TEST(DirectionDetector, AStepDecidesAtOnce) {
  DirectionDetector d(CompensatorSettings{}, 0);
  VelocityWindow win(100);
  ramp(win, 10, 0.3, 100);
  EXPECT_EQ(d.update(win, 0.3, Direction::kHold, 0), Direction::kFlexion);
  // The step detector named a stop while the window still reads the movement.
  EXPECT_EQ(d.update(win, 0.3, Direction::kHold, 100), Direction::kHold);
  // Until the window has refilled, its own velocity does not undo the step's decision...
  EXPECT_EQ(d.update(win, 0.3, Direction::kHold, 90), Direction::kHold);
  // ... but half a window after it, the scans since the step may name a movement.
  EXPECT_EQ(d.update(win, 0.3, Direction::kHold, 50), Direction::kFlexion);
}

TEST(StepDetector, OffUnlessTheBlocksFitTheWindow) {
  CompensatorSettings s;
  const auto m = pof::core::paper_coefficients();
  EXPECT_FALSE(StepDetector().enabled());
  EXPECT_TRUE(StepDetector(m, 0.0209, s, 100).enabled());
  EXPECT_FALSE(StepDetector(m, 0.0209, s, 10).enabled());  // 4 blocks of 5 scans do not fit 10
  s.step_tolerance = 1.5;
  EXPECT_THROW(StepDetector(m, 0.0209, s, 100), std::invalid_argument);
}

TEST(StepDetector, APredictedStopStepIsFoundAndTakenOut) {
  const auto m = pof::core::paper_coefficients();
  const CompensatorSettings s;
  StepDetector steps(m, 0.0209, s, 100);
  VelocityWindow win(100);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0, 0.05);
  // Learn the statistic's spread on a noisy flexion at 0.2 rad/s (more than two windows).
  double a = 20;
  for (int i = 0; i < 400; ++i) {
    a += 0.2 * pof::core::kDegPerRad / 200.0;
    steps.tick();
    win.push(a + noise(rng) - steps.offset());
    ASSERT_EQ(steps.detect(win, Direction::kFlexion), Direction::kFlexion) << "a smooth movement stepped at scan " << i;
  }
  // The knee stops; the f5 angle jumps by the step the model predicts for flexion -> hold.
  const double jump = pof::core::quasi_static_angle(m, pof::core::model_voltage(m, a, 0.0209, Direction::kHold)) -
                      pof::core::quasi_static_angle(m, pof::core::model_voltage(m, a, 0.0209, Direction::kFlexion));
  ASSERT_GT(std::abs(jump), 0.4);
  Direction named = Direction::kFlexion;
  for (int i = 0; i < 10 && named == Direction::kFlexion; ++i) {
    steps.tick();
    win.push(a + jump + noise(rng) - steps.offset());
    named = steps.detect(win, Direction::kFlexion);
  }
  EXPECT_EQ(named, Direction::kHold);
  EXPECT_NEAR(steps.offset(), jump, 0.2 * std::abs(jump));
  EXPECT_EQ(steps.hold(), 100);
  steps.clear();
  EXPECT_EQ(steps.offset(), 0);
  EXPECT_EQ(steps.hold(), 0);
}

TEST(TermChains, WithoutTermsNothingIsActive) {
  TermChains t;
  EXPECT_FALSE(t.active());
}

TEST(TermChains, TheQuietAngleTakesACreepOff) {
  pof::core::Calibration cal;
  cal.model = pof::core::paper_coefficients();
  cal.reference_level_v = 4.0;
  pof::core::GapModel g;
  pof::core::GapTerm creep;
  creep.effect = "creep";
  creep.theta = 4.0;
  creep.coefficients_v = {0.002};
  g.terms.push_back(creep);
  cal.gap = g;
  TermChains t(cal, 200.0, false);
  ASSERT_TRUE(t.active());
  // A step from 20 to 60 deg, then a hold: the fibre's voltage relaxes by the creep's basis
  // x - A (x -> A with tau 4 s) times 0.002 V/deg; the quiet angle stays at 60 deg.
  const double k = 1 - std::exp(-1.0 / (200.0 * 4.0));
  double x = 20;
  double worst_quiet = 0, worst_f5 = 0;
  for (int i = 0; i < 2000; ++i) {
    const double angle = i < 200 ? 20.0 : 60.0;
    x += k * (angle - x);
    const double v = pof::core::quasi_static_voltage(cal.model, angle) + 0.002 * (x - angle);
    t.begin_scan();
    double g_quiet = 0;
    const double y = t.quiet_angle(v, 4.0, &g_quiet);
    t.commit_quiet(y, v - g_quiet, 4.0, Direction::kHold);
    if (i > 220) {
      worst_quiet = std::max(worst_quiet, std::abs(y - angle));
      worst_f5 = std::max(worst_f5, std::abs(pof::core::quasi_static_angle(cal.model, v) - angle));
    }
  }
  EXPECT_GT(worst_f5, 1.0);  // the creep is visible in f5 alone
  EXPECT_LT(worst_quiet, 0.1 * worst_f5);
}
