#pragma once
// The calibration file (TOML, schema_version 2; version 1 files still load, with the paper model
// active), written by `pof calibrate`, read by `pof compensate` and pof-compensatord. Layout
// (docs/calibration.md):
//
//   schema_version = 2
//   sensor_id = "LEFT_KNEE"            date = "2026-11-21T05:50:00Z"   source_recording = "cal.csv"
//   reference_level_v = 4.0            # reference voltage at calibration time [V] (normalisation)
//   active_model = "dynamic"           # "paper" or "dynamic": the one the compensator runs
//   [dynamic]          degree, angle_centre_deg, angle_scale_deg, angle_min_deg, angle_max_deg,
//                      poly = [...], thresholds_deg = [...], weights_v_per_deg = [...],
//                      rate_gain_s_per_rad, speed_filter_s, speed_limit_rad_s,
//                      prony_tau_s = [...], prony_gain_v_per_deg = [...]   (dynamic_model.hpp)
//   [held_out]         paper_rmse_deg, paper_p99_deg, dynamic_rmse_deg, dynamic_p99_deg, folds
//                      (informational: what chose active_model)
//   [model]            c1, c2, c9, c10 # table 2
//   [model.flexion]    c3 .. c8        # f2 and f4 for flexion
//   [model.extension]  c3 .. c8
//   [range]            angle_min_deg, angle_max_deg, velocity_min_rad_s, velocity_max_rad_s
//   [fit_quality]      sensitivity_v_per_deg, linearity_r2, f1_r2, f1_rmse_pct, f4_flexion_r2,
//                      f4_extension_r2, n_holds, n_velocity_tests
//   [equations]        flexion, extension (eq. (11)/(12) as text; informational, not read back)
//   [potentiometer]    deg_per_volt, zero_v, offsets = [[angle_deg, correction_deg], ...] (optional)
//   [gap]              schema_version = 1, delay_s, backlash_deg, [[gap.terms]] (effect, theta,
//                      coefficients_v, thresholds_deg, relay_centres_deg, time_constants_s,
//                      [gap.terms.parameters]):
//                      the effect terms `pof gap` accepted (optional; pof/core/gap_terms.hpp)
//
// Loading validates every key (missing, wrong type, NaN/inf, impossible range) and names it with
// the file and line in the ConfigError (exit 78); a key it does not read is refused with the
// nearest known one (pof/base/toml_reader.hpp). Nothing is returned unless everything is valid.
// Whether the compensator can apply the [gap] terms is checked by load_calibration(path, model,
// rate), what the compensator's programs call, not by the parser.
#include <cstdint>
#include <optional>
#include <string>

#include "pof/core/calibration.hpp"
#include "pof/core/dynamic_fit.hpp"
#include "pof/core/potentiometer.hpp"

namespace pof::io {

// 3: [estimator] (the dynamic model's angle estimated; files without it keep the per-scan inverse).
inline constexpr int kCalibrationSchemaVersion = 3;

/// Both models' error against the reference angle on blocks held out of their fits.
struct HeldOutSummary {
  double paper_rmse_deg = 0, paper_p99_deg = 0, dynamic_rmse_deg = 0, dynamic_p99_deg = 0;
  std::int64_t folds = 0;
};

struct FitQuality {
  double sensitivity_v_per_deg = 0;  // |dV/dalpha| of the quasi-static line (paper: 0.0229)
  double linearity_r2 = 0;           // R^2 of that line (paper: 0.9992)
  double f1_r2 = 0, f1_rmse_pct = 0;
  double f4_flexion_r2 = 0, f4_extension_r2 = 0;
  std::int64_t n_holds = 0, n_velocity_tests = 0;
};

struct CalibrationFile {
  std::string sensor_id;
  std::string date;               // ISO 8601 UTC
  std::string source_recording;
  pof::core::Calibration cal;
  FitQuality quality;
  std::string equation_flexion, equation_extension;  // informational
  std::optional<pof::core::PotentiometerCalibration> potentiometer;
  std::optional<HeldOutSummary> held_out;
  std::string dynamic_note;  // why there is no dynamic model, or why it is not active (a comment)
  std::string dynamic_fit_note;  // dynamic_fit_note() of its fit, under [dynamic] (a comment)
};

/// "paper" / "dynamic", and back (nullopt for any other text).
const char* to_string(pof::core::ModelKind k);
std::optional<pof::core::ModelKind> model_kind_of(const std::string& text);

/// The model the compensator runs: `choice` "" or "file" keeps the file's active_model, "paper" or
/// "dynamic" overrides it (the --model option of pof compensate and pof-compensatord). Throws
/// ConfigError naming `source` when "dynamic" is asked of a file without a [dynamic] section.
void choose_model(CalibrationFile& f, const std::string& choice, const std::string& source);

/// Throws ConfigError when the [gap] terms of `f` cannot be applied online (core::gap_problems at
/// scan_rate_hz; 0 skips the checks that need a rate): one line per term, naming `source`, the
/// term's line, number, effect and why, e.g.
/// "model.toml:41: [gap] term 2 'drift': a trend over the calibration recording cannot be applied
/// online; remove it or recalibrate".
void require_applicable_gap(const CalibrationFile& f, const std::string& source, double scan_rate_hz);

/// Loads a calibration, applies choose_model() and require_applicable_gap(): what pof compensate
/// and pof-compensatord read. A file with a term the compensator cannot apply is refused, never
/// applied in part.
CalibrationFile load_calibration(const std::string& path, const std::string& model_choice, double scan_rate_hz = 0);

/// One line when the dynamic fit had to be held to the invertibility rule: the structure the rule
/// refused and, if the sensor runs backwards after a reversal, over how many degrees and the span
/// of angles one voltage stands for there (DynamicFitResult); empty for an ordinary fit.
std::string dynamic_fit_note(const pof::core::DynamicFitResult& fit);

/// Builds the file contents from a fit.
CalibrationFile make_calibration_file(const pof::core::CalibrationResult& r, const std::string& sensor_id,
                                      const std::string& source_recording, const std::string& date_utc);

std::string to_toml(const CalibrationFile& f);
/// Atomic (temp + rename). Throws IoError.
void save_calibration(const CalibrationFile& f, const std::string& path);
/// Throws NoInputError (missing/unreadable), ConfigError (anything invalid, naming the key).
CalibrationFile load_calibration(const std::string& path);
/// Parses TOML text; `name` is used in messages. Throws ConfigError.
CalibrationFile parse_calibration(const std::string& text, const std::string& name);

/// The [potentiometer] section of a TOML file (a calibration file or a separate one; the optional
/// schema_version must be 1 or 2). Unknown keys are refused, the calibration's own keys left to
/// load_calibration. Throws NoInputError, ConfigError.
pof::core::PotentiometerCalibration load_potentiometer(const std::string& path);

}  // namespace pof::io
