#pragma once
// The angle estimator's two noises (angle_estimator.hpp), identified from the calibration
// recording the paper's protocol already makes (docs/calibration.md, "The angle estimator"):
//
//   sigma_v  the normalised voltage's scatter in holds: sqrt(mean (v_k - v_k-1)^2 / 2) over
//            consecutive scans inside holds of the reference angle. A difference cancels the slow
//            relaxation a hold still shows, and keeps the quantisation, which is noise too.
//   sigma_a  the white acceleration of the motion model. Bar-Shalom, Li, Kirubarajan (2001),
//            sec. 6.3.2, put it at 0.5-1 x the largest acceleration the target makes: here the
//            larger of what the calibration's knee showed (the 99th percentile of |theta''| of
//            the reference angle while moving, from two centred least-squares slopes over
//            accel_window_s that average the potentiometer's noise) and half the least a knee
//            makes in an exoskeleton's gait (min_acceleration_deg_s2). The protocol's drive
//            accelerates at ~2 rad/s^2; gait at 10-30 rad/s^2, which a motion model identified
//            on the protocol alone would lag by degrees behind a bend lag.
#include <stdexcept>

#include <Eigen/Core>

#include "pof/core/angle_estimator.hpp"
#include "pof/core/segmentation.hpp"

namespace pof::core {

struct EstimatorNoiseSettings {
  SegmentationSettings segmentation;
  double min_hold_s = 1.0;         // holds at least this long give sigma_v
  double accel_window_s = 0.1;     // each of the two slopes
  // sigma_a's floor: 0.5 x 10 rad/s^2, the slow end of an exoskeleton gait's knee acceleration.
  double min_acceleration_deg_s2 = 300;
};

/// Throws std::runtime_error naming what is missing: no hold of min_hold_s, no movement, or a
/// voltage that never changes in the holds (a zero scatter cannot weigh a voltage).
EstimatorNoise identify_estimator_noise(const Eigen::VectorXd& t_s, const Eigen::VectorXd& v_normalised,
                                        const Eigen::VectorXd& angle_ref_deg, const EstimatorNoiseSettings& s = {});

}  // namespace pof::core
