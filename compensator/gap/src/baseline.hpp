#pragma once
// The baseline of `pof gap`: the model structure fitted to this recording (docs/gap.md, section 1).
#include <optional>

#include <nlohmann/json.hpp>

#include "pof/core/dynamic_model.hpp"
#include "pof/core/model.hpp"
#include "pof/gap/signals.hpp"
#include "pof/io/recording.hpp"

namespace pof::gap {

struct Baseline {
  core::ModelCoefficients model;  // the paper's structure with every coefficient fitted here
  std::optional<core::DynamicModel> dynamic;  // the dynamic model fitted here (none if it could not be)
  nlohmann::json detail;          // how they were fitted
};

/// Table-2 coefficients as JSON: c1, c2, c9, c10, flexion/extension [c3..c8] (gap.json, model).
nlohmann::json coefficients_json(const core::ModelCoefficients& m);

/// 1. The calibration procedure of `pof calibrate` (core::calibrate: f5 from the holds, f1-f4
///    from the constant-velocity tests), or the paper's table 2 when the recording has no
///    velocity tests (said in detail["start"]).
/// 2. From there, every identifiable coefficient refitted on the voltage of all scans
///    (core::refit_paper_model), so the baseline is the structure at its best on this recording.
/// 3. The dynamic model (core::fit_dynamic: structure chosen by its own cross-validation,
///    coefficients on all scans) identified on the same recording: the second baseline, which
///    analyse() takes when it explains the voltage better (docs/gap.md, section 1).
/// k0: the kinematics of the reference angle without delay (direction, speed).
Baseline fit_baseline(const io::Recording& rec, const Signals& s, const Kinematics& k0);

}  // namespace pof::gap
