#pragma once
// Which model a calibration marks active: both are scored the same way, by the error of the
// online compensator (what pof-compensatord would publish) against the reference angle on blocks
// of the recording held out of their fit. The blocks are the dynamic fit's (contiguous, cut at
// holds); for each, the paper's calibration is refitted with the block's reference removed and the
// dynamic model's chosen structure is refitted on the other blocks, then both run over the whole
// recording (their memory and velocity windows need the history) and are scored on the block.
// A block whose paper refit fails (it held every velocity test of one speed, say) is left out of
// both scores, and said so.
#include <string>
#include <vector>

#include <Eigen/Core>

#include "pof/core/calibration.hpp"
#include "pof/core/compensator.hpp"
#include "pof/core/dynamic_fit.hpp"

namespace pof::core {

struct HeldOutError {
  double rmse_deg = 0, p99_abs_deg = 0, max_abs_deg = 0;
  Eigen::Index n = 0;  // scans scored
};

struct ModelComparison {
  HeldOutError paper, dynamic;
  int folds = 0, folds_used = 0;
  std::vector<std::string> notes;          // folds left out and why
  Eigen::VectorXd paper_deg, dynamic_deg;  // held-out angle of each scan (NaN where not scored)
};

/// settings.scan_rate_hz is taken from the recording, as compensate_recording() does.
ModelComparison compare_held_out(const Eigen::VectorXd& t_s, const Eigen::VectorXd& sensor_v,
                                 const Eigen::VectorXd& reference_v, const Eigen::VectorXd& angle_ref_deg,
                                 const DynamicFitResult& dynamic, const CalibrationSettings& paper_settings = {},
                                 const DynamicFitSettings& dynamic_settings = {},
                                 const CompensatorSettings& settings = {});

/// |error| statistics of a - b over the scans where both are finite.
HeldOutError error_stats(const Eigen::VectorXd& a, const Eigen::VectorXd& b);

}  // namespace pof::core
