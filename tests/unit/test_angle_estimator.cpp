// The angle estimator (angle_estimator.hpp) on data made by its own models: consistency of its
// innovations and errors (NIS, NEES), its gain over the per-scan inverse, restarts, lost scans
// and the fixed-lag smoother.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "pof/core/angle_estimator.hpp"
#include "pof/core/compensator.hpp"

namespace {

using pof::core::AngleEstimator;
using pof::core::DynamicKernel;
using pof::core::DynamicModel;
using pof::core::DynamicState;
using pof::core::EstimatorNoise;

constexpr double kRate = 200, kDt = 1 / kRate;
constexpr double kSigmaV = 0.0015, kSigmaA = 100;

// A fibre like those `pof calibrate` identifies: a line, three stop operators, one Prony term.
DynamicModel fibre(double bend_lag_s = 0) {
  DynamicModel m;
  m.degree = 1;
  m.poly = {2.0, -0.99, 0, 0, 0, 0};  // -0.022 V/deg
  m.n_operators = 3;
  m.threshold_deg = {1.0, 3.0, 8.0};
  m.weight_v_per_deg = {0.002, 0.0015, 0.001};
  m.n_prony = 1;
  m.prony_tau_s = {2.0};
  m.prony_gain_v_per_deg = {-0.0003};
  m.bend_lag_s = bend_lag_s;
  EXPECT_STREQ(m.invalid_reason(), "");
  return m;
}

struct Trace {
  std::vector<double> truth, v;
};

// theta from the estimator's own motion model (white acceleration sigma_a per scan) from rest at
// 45 deg: over 2 s it wanders ~12 deg, inside the model's range; v from the forward model plus
// white noise.
Trace simulate(const DynamicModel& m, int scans, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> accel(0, kSigmaA), noise(0, kSigmaV);
  const DynamicKernel k(m, kRate);
  pof::core::BendLag lag(m.bend_lag_s, kRate);
  DynamicState s;
  Trace r;
  double theta = 45, omega = 0;
  for (int i = 0; i < scans; ++i) {
    const double a = accel(rng);
    theta += kDt * omega + 0.5 * kDt * kDt * a;
    omega += kDt * a;
    r.truth.push_back(theta);
    r.v.push_back(k.forward(s, lag.step(theta)) + noise(rng));
  }
  return r;
}

double rmse(const std::vector<double>& a, const std::vector<double>& b, std::size_t from, int shift = 0) {
  double s = 0;
  std::size_t n = 0;
  for (std::size_t i = from + static_cast<std::size_t>(shift); i < a.size(); ++i, ++n) {
    const double e = a[i] - b[i - static_cast<std::size_t>(shift)];
    s += e * e;
  }
  return std::sqrt(s / static_cast<double>(n));
}

// Bar-Shalom, Li, Kirubarajan (2001), sec. 5.4: on data from the filter's own models the mean NIS
// (1 degree of freedom) and the mean NEES of the angle are 1. Over 100 runs x 400 scans the
// samples are correlated by the motion, so the test allows +-25 %, far inside what a mistuned
// filter shows (a sigma_v wrong by 3x moves the NIS by 2x or more; checked below).
TEST(AngleEstimator, InnovationsAndErrorsAreConsistentOnItsOwnModels) {
  for (const double lag_s : {0.0, 0.08}) {
    const DynamicModel m = fibre(lag_s);
    double nis = 0, nees = 0;
    long n = 0;
    for (unsigned seed = 1; seed <= 100; ++seed) {
      const Trace r = simulate(m, 400, seed);
      AngleEstimator est(m, EstimatorNoise{kSigmaV, kSigmaA}, kRate);
      for (std::size_t i = 0; i < r.v.size(); ++i) {
        const auto out = est.step(r.v[i]);
        if (i < 40) continue;  // the start's wide rate variance settles
        nis += out.nis;
        nees += std::pow(out.angle_deg - r.truth[i], 2) / (out.sigma_deg * out.sigma_deg);
        ++n;
      }
      EXPECT_EQ(est.divergences(), 0) << "seed " << seed;
    }
    nis /= static_cast<double>(n);
    nees /= static_cast<double>(n);
    EXPECT_NEAR(nis, 1.0, 0.25) << "bend lag " << lag_s;
    EXPECT_NEAR(nees, 1.0, 0.25) << "bend lag " << lag_s;
  }
}

TEST(AngleEstimator, AMistunedVoltageNoiseFailsTheConsistencyCheck) {
  const DynamicModel m = fibre();
  double nis = 0;
  long n = 0;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const Trace r = simulate(m, 400, seed);
    AngleEstimator est(m, EstimatorNoise{kSigmaV / 3, kSigmaA}, kRate);  // trusts the voltage 9x too much
    for (std::size_t i = 0; i < r.v.size(); ++i) {
      const double x = est.step(r.v[i]).nis;
      if (i < 40) continue;
      nis += x;
      ++n;
    }
  }
  EXPECT_GT(nis / static_cast<double>(n), 2.0);
}

// The gain over the per-scan inverse, with and without a bend lag: the inverse divides the noise
// by the slope and (with a lag) differentiates it.
TEST(AngleEstimator, BeatsThePerScanInverseOnTheSameVoltages) {
  for (const double lag_s : {0.0, 0.08}) {
    const DynamicModel m = fibre(lag_s);
    const Trace r = simulate(m, 400, 7);
    AngleEstimator est(m, EstimatorNoise{kSigmaV, kSigmaA}, kRate);
    pof::core::DynamicInverter inv(m, kRate);
    std::vector<double> e, d;
    for (const double v : r.v) {
      e.push_back(est.step(v).angle_deg);
      d.push_back(inv.step(v).angle_deg);
    }
    const double re = rmse(e, r.truth, 40), rd = rmse(d, r.truth, 40);
    EXPECT_LT(re, 0.7 * rd) << "bend lag " << lag_s << ": estimate " << re << ", inverse " << rd;
    EXPECT_LT(re, 0.15) << "bend lag " << lag_s;
  }
}

// A fixed lag of L scans: the angle L scans back, smoothed by the scans since, is closer to the
// truth then than the causal estimate was.
TEST(AngleEstimator, FixedLagSmootherIsMoreAccurateThanTheFilter) {
  const DynamicModel m = fibre(0.08);
  const Trace r = simulate(m, 400, 8);
  AngleEstimator causal(m, EstimatorNoise{kSigmaV, kSigmaA}, kRate);
  AngleEstimator smooth(m, EstimatorNoise{kSigmaV, kSigmaA}, kRate, 10);
  EXPECT_EQ(smooth.lag_scans(), 10);
  std::vector<double> c, s;
  for (const double v : r.v) {
    c.push_back(causal.step(v).angle_deg);
    s.push_back(smooth.step(v).angle_deg);
  }
  const double rc = rmse(c, r.truth, 40), rs = rmse(s, r.truth, 40, 10);
  EXPECT_LT(rs, 0.85 * rc) << "smoothed " << rs << ", causal " << rc;
  EXPECT_GT(rmse(s, r.truth, 40, 0), rc) << "the smoothed angle is the one 10 scans back";
}

// A voltage that jumps by 20 deg worth (a knock, a slipped fibre) is followed within 50 ms: the
// innovations raise the process noise at once. One the model cannot give at any angle (beyond its
// range) keeps them beyond their gate: a divergence, a restart from the direct inverse, flagged,
// and never a NaN.
TEST(AngleEstimator, AJumpIsFollowedAndAnImpossibleVoltageRestarts) {
  const DynamicModel m = fibre();
  AngleEstimator est(m, EstimatorNoise{kSigmaV, kSigmaA}, kRate);
  DynamicState s;
  const DynamicKernel k(m, kRate);
  for (int i = 0; i < 200; ++i) {
    const auto out = est.step(k.forward(s, i < 100 ? 40.0 : 60.0));
    ASSERT_TRUE(std::isfinite(out.angle_deg));
    if (i >= 110) {
      EXPECT_NEAR(out.angle_deg, 60.0, 0.5) << "scan " << i;
    }
  }
  const double impossible = k.voltage_at(s, est.step(k.forward(s, 60.0)).angle_deg + 300, nullptr);
  int restarts = 0, clamped = 0;
  for (int i = 0; i < 100; ++i) {
    const auto out = est.step(impossible);
    ASSERT_TRUE(std::isfinite(out.angle_deg));
    restarts += out.restarted ? 1 : 0;
    clamped += out.clamped ? 1 : 0;
  }
  EXPECT_GE(est.divergences(), 1);
  EXPECT_EQ(restarts, est.divergences());
  EXPECT_GT(clamped, 50);
}

TEST(AngleEstimator, NonFiniteVoltagePredictsAndResetRestarts) {
  const DynamicModel m = fibre();
  AngleEstimator est(m, EstimatorNoise{kSigmaV, kSigmaA}, kRate);
  EXPECT_TRUE(std::isnan(est.step(std::nan("")).angle_deg));  // nothing known yet
  DynamicState s;
  const DynamicKernel k(m, kRate);
  double theta = 30;
  for (int i = 0; i < 200; ++i) est.step(k.forward(s, theta += 0.1));  // 20 deg/s
  const auto predicted = est.step(std::nan(""));
  EXPECT_NEAR(predicted.angle_deg, theta + 0.1, 0.05);  // carried on at the rate
  est.reset();
  const auto fresh = est.step(k.forward(s, 50.0));
  EXPECT_TRUE(fresh.restarted);
  EXPECT_EQ(est.divergences(), 0);
}

// Through the compensator: a calibration with [estimator] estimates, one without inverts as before,
// and lost scans restart the estimator with the flags the stream expects.
TEST(AngleEstimator, TheCompensatorEstimatesOnlyWithTheCalibrationsNoises) {
  pof::core::Calibration cal;
  cal.model = pof::core::paper_coefficients();
  cal.reference_level_v = 4.0;
  cal.dynamic = fibre();
  cal.active = pof::core::ModelKind::kDynamic;
  pof::core::OnlineCompensator inverting(cal);
  EXPECT_FALSE(inverting.estimating());
  cal.estimator = EstimatorNoise{kSigmaV, kSigmaA};
  pof::core::OnlineCompensator estimating(cal);
  EXPECT_TRUE(estimating.estimating());
  pof::core::CompensatorSettings off;
  off.estimate = false;
  EXPECT_FALSE(pof::core::OnlineCompensator(cal, off).estimating());
  pof::core::CompensatorSettings too_long;
  too_long.estimator_lag_s = 2.0;  // 400 scans: beyond kMaxSmootherLag
  EXPECT_THROW(pof::core::OnlineCompensator(cal, too_long), std::invalid_argument);
  cal.estimator->voltage_noise_v = -1;
  EXPECT_THROW(pof::core::OnlineCompensator{cal}, std::invalid_argument);

  const Trace r = simulate(*cal.dynamic, 400, 3);
  for (std::size_t i = 0; i < 200; ++i) estimating.step(r.v[i], 4.0);
  estimating.reset();
  const auto first = estimating.step(r.v[200], 4.0);
  EXPECT_TRUE(first.quality & pof::core::quality::kScansLost);
  EXPECT_TRUE(first.quality & pof::core::quality::kSettling);
  EXPECT_NEAR(first.angle_deg, r.truth[200], 1.5);  // the inverse at a relaxed memory
  pof::core::CompensatedScan last;
  for (std::size_t i = 201; i < 400; ++i) last = estimating.step(r.v[i], 4.0);
  EXPECT_NEAR(last.angle_deg, r.truth[399], 0.5);
}

// A fixed lag of L scans: step() returns, whole, the record of the scan L back (its uncompensated
// angle is the one a causal compensator gave then), its angle smoothed; the first L are NaN and
// settling, and so are the L after lost scans.
TEST(AngleEstimator, TheCompensatorsFixedLagReturnsTheWholeRecordOfTheScanLBack) {
  pof::core::Calibration cal;
  cal.model = pof::core::paper_coefficients();
  cal.reference_level_v = 4.0;
  cal.dynamic = fibre(0.08);
  cal.active = pof::core::ModelKind::kDynamic;
  cal.estimator = EstimatorNoise{kSigmaV, kSigmaA};
  constexpr int kLag = 5;
  pof::core::CompensatorSettings lagged;
  lagged.estimator_lag_s = kLag / lagged.scan_rate_hz;
  pof::core::OnlineCompensator causal(cal), late(cal, lagged);
  EXPECT_EQ(late.lag_scans(), kLag);
  EXPECT_EQ(causal.lag_scans(), 0);
  const Trace r = simulate(*cal.dynamic, 400, 4);
  std::vector<pof::core::CompensatedScan> c, l;
  for (std::size_t i = 0; i < r.v.size(); ++i) {
    if (i == 300) {
      causal.reset();
      late.reset();
    }
    c.push_back(causal.step(r.v[i], 4.0));
    l.push_back(late.step(r.v[i], 4.0));
  }
  double se_c = 0, se_l = 0;
  for (std::size_t i = 0; i < l.size(); ++i) {
    const bool none = i < kLag || (i >= 300 && i < 300 + kLag);
    if (none) {
      EXPECT_TRUE(std::isnan(l[i].angle_deg)) << i;
      EXPECT_TRUE(l[i].quality & pof::core::quality::kSettling) << i;
      continue;
    }
    const auto& then = c[i - kLag];
    EXPECT_EQ(l[i].angle_uncomp_deg, then.angle_uncomp_deg) << i;
    EXPECT_EQ(l[i].quality & pof::core::quality::kScansLost, then.quality & pof::core::quality::kScansLost) << i;
    if (i > 40 && i < 300) {
      se_c += std::pow(then.angle_deg - r.truth[i - kLag], 2);
      se_l += std::pow(l[i].angle_deg - r.truth[i - kLag], 2);
    }
  }
  EXPECT_LT(se_l, se_c);  // smoothed by the kLag scans since
}

}  // namespace
