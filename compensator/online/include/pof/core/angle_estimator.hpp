#pragma once
// The online angle estimated from the dynamic model instead of inverted scan by scan
// (docs/calibration.md, "The angle estimator"). A per-scan inverse divides the voltage noise by the
// model's local slope, which the stop operators flatten after every reversal, and the bend-lag
// inverse differentiates that again. The estimator weighs each voltage against what the knee's
// motion predicts instead, trusting the prediction where the slope is small.
//
//   state      x = [theta, omega, lag]: the joint angle [deg], its rate [deg/s] and the bend lag
//              theta - theta_f [deg] (0 without one). The operators, Prony states and speed
//              filters are NOT in x: they are a deterministic function of the fibre's angle
//              history and are propagated from the estimate (one commit per scan, as the
//              inverse does), which keeps the filter at 3 states whatever the structure.
//   motion     discrete white-noise acceleration (Bar-Shalom, Li, Kirubarajan 2001, sec. 6.3.2):
//              the acceleration is constant over a scan and white across scans, of standard
//              deviation sigma_a, raised while the innovations say the knee accelerates more
//              (kAdaptTimeS); the lag follows its own first-order law (dynamic_model.hpp).
//   measure    v = h(theta - lag) + e, h the dynamic model's forward voltage given the memory,
//              e white of standard deviation sigma_v (EstimatorNoise).
//   filter     iterated extended Kalman filter (Sarkka 2013, sec. 5.3, 5.4): h is piecewise smooth
//              (an operator yields at a kink), so the update is relinearised at its own result, at
//              most kIterations times.
//
// Optional fixed lag L (a fixed-lag Rauch-Tung-Striebel smoother, Sarkka 2013, ch. 8 and 12):
// the angle of the scan L scans back, smoothed by the L scans since; the default is causal (L = 0).
//
// Bad input: a non-finite voltage is a prediction without an update. A normalised innovation
// squared beyond its chi-square 99.9 % bound for a run of kDivergenceRunS is a divergence (a knock,
// a slipped fibre, an angle the motion model cannot follow): the filter restarts from the direct
// inverse (DynamicInverter::solve) and says so. Never allocates, never throws; O(operators +
// Prony terms) per iteration plus O(L) for the smoother.
#include <array>

#include <Eigen/Core>

#include "pof/core/dynamic_model.hpp"

namespace pof::core {

/// What the estimator knows of its two noises, identified from the calibration recording
/// (identify_estimator_noise(), dynamic_fit.hpp) and stored in the calibration file's [estimator].
struct EstimatorNoise {
  double voltage_noise_v = 0;            // sigma_v: the normalised voltage's scatter in holds [V]
  double acceleration_noise_deg_s2 = 0;  // sigma_a: the motion model's white acceleration [deg/s^2]
  /// A human-readable reason the values cannot be run (not finite, not > 0), else "".
  [[nodiscard]] const char* invalid_reason() const;
};

inline constexpr int kMaxSmootherLag = 256;  // scans (1.28 s at 200 Hz, 128 ms at 2000 Hz)

class AngleEstimator {
 public:
  AngleEstimator() = default;
  /// m must be valid (invalid_reason() empty) and n too; lag_scans is clamped to
  /// 0..kMaxSmootherLag.
  AngleEstimator(const DynamicModel& m, const EstimatorNoise& n, double scan_rate_hz, int lag_scans = 0);

  struct Result {
    double angle_deg = 0;        // the joint angle (lag_scans back when smoothing); NaN before the first voltage
                                 // and, when smoothing, for the lag_scans after each (re)start
    double rate_deg_s = 0;       // its rate
    double sigma_deg = 0;        // the estimate's standard deviation
    double nis = 0;              // this scan's normalised innovation squared (0 without an update)
    bool clamped = false;        // the fibre angle left the model's search range: held at its bound
    bool restarted = false;      // started or restarted from the direct inverse at this scan
  };
  /// One scan's normalised voltage v [V]. A non-finite v predicts without an update.
  Result step(double v) noexcept;
  /// Lost scans: the next voltage starts again from the direct inverse with a relaxed memory.
  void reset() noexcept;
  /// Restarts after a divergence since construction.
  [[nodiscard]] long divergences() const noexcept { return divergences_; }
  [[nodiscard]] int lag_scans() const noexcept { return lag_; }

  static constexpr int kIterations = 3;
  static constexpr double kNisGate = 10.83;       // chi-square, 1 degree of freedom, 99.9 %
  static constexpr double kDivergenceRunS = 0.05;
  static constexpr double kAdaptTimeS = 0.05;    // the innovations' fading memory for Q's scale
  static constexpr double kMaxNoiseScale = 1000;  // Q at most this x sigma_a^2  // this long beyond the gate is a divergence

 private:
  using Vec = Eigen::Vector3d;
  using Mat = Eigen::Matrix3d;
  struct Slot {  // one scan of the smoother's history
    Vec x_filt = Vec::Zero(), x_pred = Vec::Zero();
    Mat p_filt = Mat::Zero(), p_pred = Mat::Zero();
  };
  void start(double v, Result& r) noexcept;
  void remember(const Vec& x_pred, const Mat& p_pred) noexcept;
  void publish(Result& r) const noexcept;

  DynamicKernel k_;
  DynamicInverter inverse_;  // the direct inverse, for a start and a restart
  DynamicState memory_;
  Mat f_ = Mat::Identity();  // the motion model's transition
  Vec g_ = Vec::Zero();      // how one scan's acceleration enters x
  double r_ = 1e-6, q_ = 0;  // sigma_v^2, sigma_a^2
  double nis_mean_ = 1, nis_alpha_ = 0, q_scale_ = 1;
  double bend_lag_s_ = 0;
  Vec x_ = Vec::Zero();
  Mat p_ = Mat::Zero();
  bool started_ = false;
  int beyond_gate_ = 0, divergence_run_ = 1;
  long divergences_ = 0;
  int lag_ = 0, filled_ = 0, head_ = 0;  // the smoother's lag and ring of lag_ + 1 slots
  std::array<Slot, kMaxSmootherLag + 1> history_{};
};

}  // namespace pof::core
