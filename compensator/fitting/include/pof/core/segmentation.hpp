#pragma once
// Segmentation of a recording's reference angle into holds, flexion sweeps (angle increasing, the
// fibre's loading cycle) and extension sweeps (unloading), each sweep with its velocity. This is
// offline (whole arrays); the online compensator has its own causal direction detector.
//
// Rules (docs/calibration.md):
//  1. velocity: least-squares slope of the angle over a centred window (velocity_window_s), which
//     averages noise and quantisation of the potentiometer;
//  2. each sample is moving or holding with hysteresis: it starts moving above move_deg_s and stops
//     below hold_deg_s (a dead band, so noise at a threshold does not chatter);
//  3. runs shorter than min_run_s are absorbed by their neighbours; a hold shorter than
//     max_pause_s between two sweeps of the same direction is bridged (a stutter, not a stop);
//     a short pause at a reversal stays a hold between the two sweeps;
//  4. a sweep whose amplitude is below min_sweep_deg becomes a hold (drift, not movement);
//  5. a sweep's velocity is the median of the windowed slopes over its central part (trim_s removed
//     at each end where the drive accelerates): the cruise speed, even across a stutter; rad/s,
//     signed, positive in flexion.
// Partial cycles (a recording that starts or ends mid-sweep) simply give a shorter first/last sweep.
#include <vector>

#include <Eigen/Core>

#include "pof/core/model.hpp"

namespace pof::core {

struct SegmentationSettings {
  double velocity_window_s = 0.5;
  double move_deg_s = 0.5;      // |velocity| above which a hold becomes movement
  double hold_deg_s = 0.25;     // |velocity| below which movement becomes a hold
  double min_run_s = 0.3;
  double max_pause_s = 1.0;
  double min_sweep_deg = 1.0;
  double trim_s = 0.25;
};

struct Segment {
  Direction kind = Direction::kHold;
  Eigen::Index begin = 0, end = 0;  // samples [begin, end)
  double t_begin = 0, t_end = 0;    // [s]
  double angle_begin = 0, angle_end = 0;  // reference angle at the ends [deg]
  double velocity_rad_s = 0;        // cruise velocity, signed (0 for holds)
  Eigen::Index core_begin = 0, core_end = 0;  // central part used for fits (trim_s removed)

  [[nodiscard]] Eigen::Index size() const { return end - begin; }
  [[nodiscard]] double duration_s() const { return t_end - t_begin; }
  [[nodiscard]] double amplitude_deg() const { return angle_end - angle_begin; }
};

/// Centred least-squares slope of y(t) over a window of about window_s [unit of y per s]; O(n).
Eigen::VectorXd centred_slope(const Eigen::VectorXd& t, const Eigen::VectorXd& y, double window_s);

/// Splits [0, n) into consecutive segments covering every sample. NaN angles count as holds.
std::vector<Segment> segment(const Eigen::VectorXd& t_s, const Eigen::VectorXd& angle_deg,
                             const SegmentationSettings& s = {});

}  // namespace pof::core
