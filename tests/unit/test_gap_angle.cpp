// `pof gap`'s compensated angle against the forward gap (pof/gap/angle_gap.hpp; docs/gap.md,
// section 5, "Angle against the forward gap"): synthetic angles whose error is known, so the
// verdict (noise amplification, or bias and where) can be checked against what was put in.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "pof/gap/angle_gap.hpp"
#include "pof/gap/localise.hpp"
#include "pof/gap/signals.hpp"

namespace {

using Eigen::Index;
using Eigen::VectorXd;

constexpr double kDt = 0.005;  // 200 Hz, the simulated sessions' rate

// Holds, sweeps at several speeds and direct reversals: every segment of the comparison is populated.
VectorXd trajectory() {
  std::vector<double> a;
  double x = 10;
  auto hold = [&](double s) { for (int i = 0; i < static_cast<int>(s / kDt); ++i) a.push_back(x); };
  auto move = [&](double to, double rad_s) {
    const double step = rad_s * 180.0 / std::numbers::pi * kDt * (to > x ? 1 : -1);
    while ((step > 0 && x + step < to) || (step < 0 && x + step > to)) { x += step; a.push_back(x); }
    x = to;
    a.push_back(x);
  };
  for (int cycle = 0; cycle < 3; ++cycle) {
    hold(5);
    move(80, 0.1);
    hold(5);
    move(10, 0.3);
    move(60, 0.6);  // a reversal without a hold
    move(20, 0.2);
    hold(4);
  }
  return Eigen::Map<VectorXd>(a.data(), static_cast<Index>(a.size()));
}

struct Case {
  VectorXd truth, forward;
  pof::gap::Kinematics k;
  std::vector<pof::gap::Phase> phases;
  std::mt19937_64 rng{5};

  Case() : truth(trajectory()) {
    k = pof::gap::make_kinematics(truth, kDt, 0.0);
    phases = pof::gap::classify_phases(k, kDt);
    forward = white(0.05);
  }
  VectorXd white(double sd) {
    std::normal_distribution<double> g(0.0, sd);
    VectorXd e(truth.size());
    for (Index i = 0; i < e.size(); ++i) e(i) = g(rng);
    return e;
  }
  // The forward gap and the input's noise are the same white 0.05 deg throughout.
  nlohmann::json compare(const VectorXd& angle) const {
    const double gap = std::sqrt(forward.squaredNorm() / static_cast<double>(forward.size()));
    return pof::gap::compare_angle({.angle_deg = angle,
                                    .reference_deg = truth,
                                    .smooth_reference_deg = truth,
                                    .forward_deg = forward,
                                    .input_noise_deg = forward,
                                    .k = k,
                                    .phases = phases,
                                    .forward_gap_deg = gap})
        .report;
  }
  [[nodiscard]] bool hold(Index i) const {
    const pof::gap::Phase p = phases[static_cast<std::size_t>(i)];
    return p == pof::gap::Phase::kHold || p == pof::gap::Phase::kAfterStop;
  }
};

double segment_rmse(const nlohmann::json& r, const std::string& name) {
  for (const auto& s : r["segments"])
    if (s["segment"] == name) return s["rmse_deg"].get<double>();
  ADD_FAILURE() << "no segment " << name << " in " << r["segments"].dump();
  return 0;
}

TEST(GapAngle, SegmentsArePopulated) {
  Case c;
  const nlohmann::json r = c.compare(c.truth + c.white(0.05));
  ASSERT_EQ(r["segments"].size(), 5U) << r["segments"].dump();
  double share = 0;
  for (const auto& s : r["segments"]) share += s["share_of_scans"].get<double>();
  EXPECT_NEAR(share, 1.0, 1e-9);
  EXPECT_GT(segment_rmse(r, "reversals"), 0.0);
}

TEST(GapAngle, LikeTheForwardGapIsComparable) {
  Case c;
  const nlohmann::json r = c.compare(c.truth + c.white(0.05));
  EXPECT_EQ(r["verdict"].get<std::string>(), "comparable") << r["summary"];
  EXPECT_TRUE(r["where"].is_null());
  EXPECT_NEAR(r["ratio"].get<double>(), 1.0, 0.1);
  EXPECT_NEAR(r["noise"]["amplification"].get<double>(), 1.0, 0.1);
}

TEST(GapAngle, WhiteNoiseMuchLargerThanTheInputsIsNoiseAmplification) {
  Case c;
  VectorXd angle = c.truth + c.white(0.5);
  for (Index i = 100; i < angle.size(); i += 997) angle(i) = std::nan("");  // scans without an angle are skipped
  const nlohmann::json r = c.compare(angle);
  EXPECT_EQ(r["verdict"].get<std::string>(), "noise_amplification") << r["summary"];
  EXPECT_NEAR(r["angle_rmse_deg"].get<double>(), 0.5, 0.02);
  EXPECT_LT(r["angle_scans"].get<Index>(), angle.size());
  EXPECT_NEAR(r["noise"]["output_deg"]["holds"].get<double>(), 0.5, 0.03);
  EXPECT_NEAR(r["noise"]["output_deg"]["moving"].get<double>(), 0.5, 0.03);
  EXPECT_NEAR(r["noise"]["input_deg"]["all"].get<double>(), 0.05, 0.005);
  EXPECT_GT(r["noise"]["amplification"].get<double>(), 8.0);
  EXPECT_GT(r["noise"]["share_of_excess"].get<double>(), 0.9);
  EXPECT_NE(r["summary"].get<std::string>().find("noise amplification"), std::string::npos) << r["summary"];
}

TEST(GapAngle, AnOffsetInHoldsIsBiasInHolds) {
  Case c;
  VectorXd angle = c.truth + c.white(0.05);
  for (Index i = 0; i < angle.size(); ++i)
    if (c.hold(i)) angle(i) += 0.6;
  const nlohmann::json r = c.compare(angle);
  EXPECT_EQ(r["verdict"].get<std::string>(), "bias") << r["summary"];
  EXPECT_EQ(r["where"].get<std::string>(), "holds") << r["summary"];
  EXPECT_NEAR(segment_rmse(r, "holds"), std::hypot(0.6, 0.05), 0.02);
  EXPECT_NEAR(segment_rmse(r, "reversals"), 0.05, 0.01);
  // A slow error adds next to nothing to the scan-to-scan noise.
  EXPECT_NEAR(r["noise"]["amplification"].get<double>(), 1.0, 0.1);
  EXPECT_LT(r["noise"]["share_of_excess"].get<double>(), 0.1);
}

TEST(GapAngle, AWrongBranchAfterReversalsIsBiasAtReversals) {
  Case c;
  VectorXd angle = c.truth + c.white(0.05);
  for (Index i = 0; i < angle.size(); ++i)
    if (c.phases[static_cast<std::size_t>(i)] == pof::gap::Phase::kReversal) angle(i) -= 1.5;
  const nlohmann::json r = c.compare(angle);
  EXPECT_EQ(r["verdict"].get<std::string>(), "bias") << r["summary"];
  EXPECT_EQ(r["where"].get<std::string>(), "reversals") << r["summary"];
  EXPECT_NE(r["summary"].get<std::string>().find("mostly in reversals"), std::string::npos) << r["summary"];
}

}  // namespace
