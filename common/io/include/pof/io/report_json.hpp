#pragma once
// JSON reports: every figure of a calibration fit, and the table-3 statistics of a compensation run
// (keys other tools rely on: {"cycles": [{"cycle", "velocity_rad_s", "rmse_comp_deg",
// "rmse_uncomp_deg", "hysteresis_comp_pct", "hysteresis_uncomp_pct", "max_error_deg"}],
// "overall": {same keys but cycle}}; extra keys are additions, never renames).
#include <vector>

#include <nlohmann/json.hpp>

#include "pof/core/calibration.hpp"
#include "pof/core/dynamic_fit.hpp"
#include "pof/core/model_selection.hpp"
#include "pof/core/statistics.hpp"

namespace pof::io {

nlohmann::json calibration_report(const pof::core::CalibrationResult& r);

/// The dynamic model's parameters (degree, polynomial, operators, rate gain, Prony terms, bend lag).
nlohmann::json dynamic_model_json(const pof::core::DynamicModel& m);

/// The dynamic model: parameters, every structure cross-validated, and (if given) both models'
/// held-out errors.
nlohmann::json dynamic_report(const pof::core::DynamicFitResult& d, const pof::core::ModelComparison* held_out);

nlohmann::json statistics_report(const std::vector<pof::core::CycleStats>& cycles, const pof::core::CycleStats& overall,
                                 const pof::core::ErrorProfile& profile);

/// JSON text with NaN/inf written as null (JSON has no NaN).
std::string dump(const nlohmann::json& j);

}  // namespace pof::io
