#pragma once
// The compensated angle against the forward gap (docs/gap.md, section 5, "Angle against the
// forward gap"). The forward gap is the model's held-out voltage residual in degrees; the angle
// the compensator outputs can be much worse than it, because the inverse (or the estimator)
// amplifies the sensor's noise, or because it reads a biased angle somewhere (a wrong branch after
// a reversal, an offset in holds). Which of the two, and where, is what to fix next, so the
// report says it whenever the angle is more than kAngleGapRatio times the forward gap.
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "pof/gap/localise.hpp"
#include "pof/gap/signals.hpp"

namespace pof::gap {

/// Above this ratio of the angle's RMSE to the forward gap, the report says where it comes from.
inline constexpr double kAngleGapRatio = 1.5;

/// Every vector has one value per scan.
struct AngleGapInputs {
  const Eigen::VectorXd& angle_deg;             // the compensator's angle (NaN: no angle at that scan)
  const Eigen::VectorXd& reference_deg;         // the reference it is scored against (compensated.rmse_*)
  const Eigen::VectorXd& smooth_reference_deg;  // the same, smoothed (Signals::angle): for the noise
  const Eigen::VectorXd& forward_deg;           // the model's held-out voltage residual in degrees
  const Eigen::VectorXd& input_noise_deg;       // that residual [V] over the local quasi-static slope
  const Kinematics& k;                          // of the reference: |w| for the speed bins
  const std::vector<Phase>& phases;             // classify_phases: holds, reversals, moving
  double forward_gap_deg = 0;                   // the headline forward gap (final_gap_deg)
};

struct AngleGap {
  nlohmann::json report;  // gap.json's "angle_vs_forward"
  std::string summary;    // 1-2 lines for the printed summary and report.md
};

/// The angle's RMSE beside the forward gap; scan-to-scan noise of the output against the input's
/// (sqrt(mean(diff^2) / 2), over holds and over moving scans); the angle error by segment (holds,
/// reversals, and the other moving scans in |w| terciles) beside the forward residual there. When
/// the ratio exceeds kAngleGapRatio the verdict is "noise_amplification" if the output's noise
/// variance beyond the input's makes at least half of the angle's mean square beyond the forward
/// gap's, else "bias", where being the segment that adds the most squared error beyond the forward
/// residual's; below the ratio, "comparable".
AngleGap compare_angle(const AngleGapInputs& in);

}  // namespace pof::gap
