#pragma once
// Calibration fitting: the procedure of Leal-Junior et al. 2017, section 2.2 / figure 5, from one
// recording holding a quasi-static test (holds) and constant-velocity flexion/extension cycles.
//
//   f5  average the settled part of each hold; fit angle = -c9 V + c10 (fig. 6)
//   eq1 per velocity: hysteresis of the voltage-vs-angle loop (eq. 1), magnitude
//   f1  h = c1 exp(c2 w) over the velocities (log-linear start + Gauss-Newton)
//   f3  per velocity and direction: regression of the quasi-static voltage f5^-1(angle_ref) on the
//       measured voltage, V_qs = a_x V + b_x (fig. 7a)
//   f2  a_x and b_x against h, one line each (fig. 7b). The lines are fitted against f1(w), the
//       hysteresis the combined equation will evaluate, rather than the scattered measured h.
//   f4  per direction, all dynamic samples: V_qs = c7 V1 - c8 with V1 = a_x(f1(w)) V + b_x(f1(w))
// The combined equations (11)/(12) follow from combined_equation(model, direction).
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "pof/core/angle_estimator.hpp"
#include "pof/core/dynamic_model.hpp"
#include "pof/core/fit.hpp"
#include "pof/core/gap_terms.hpp"
#include "pof/core/model.hpp"
#include "pof/core/paper_protocol.hpp"
#include "pof/core/segmentation.hpp"

namespace pof::core {

/// Which sensor model turns voltage into angle: the paper's step model (eqs. (11)/(12) switched by
/// a velocity estimate, f5 in holds) or the dynamic model (dynamic_model.hpp, inverted online).
enum class ModelKind : int { kPaper = 0, kDynamic = 1 };

/// What the online compensator needs: the models, the reference level and the calibrated ranges.
struct Calibration {
  ModelCoefficients model;             // the paper's model (always present; f5 is the uncompensated angle)
  std::optional<DynamicModel> dynamic; // the dynamic model, when one was identified
  // Its estimator's noises (angle_estimator.hpp); without them (files before schema 3) the
  // dynamic model is inverted scan by scan, as then.
  std::optional<EstimatorNoise> estimator;
  ModelKind active = ModelKind::kPaper;
  double reference_level_v = 1.0;      // reference voltage at calibration time [V]
  double angle_min_deg = 0, angle_max_deg = 90;
  double velocity_min_rad_s = kTable1Velocities.front(), velocity_max_rad_s = kTable1Velocities.back();
  std::optional<GapModel> gap;         // effect terms `pof gap` accepted (gap_terms.hpp), applied on top of the active model
};

struct CalibrationSettings {
  SegmentationSettings segmentation;
  double min_hold_s = 3.0;           // holds used by f5 (the protocol holds 10 s)
  double settle_fraction = 0.3;      // first part of each hold dropped (creep, the drive settling)
  double min_dynamic_sweep_deg = 20; // shorter sweeps are quasi-static steps, not dynamic tests
  double velocity_tolerance = 0.08;  // sweeps within 8 % of each other are one test (table 1 is >= 15 % apart)
  double reference_level_v = 0;      // 0: median of the recording's reference
};

struct VelocityTest {
  double velocity_rad_s = 0;         // mean |velocity| of the test's sweeps
  int n_flexion = 0, n_extension = 0;
  Eigen::Index n_samples = 0;
  Hysteresis hysteresis;             // eq. (1) on V(angle_ref) of all the test's sweeps
  double h_pct = 0;                  // |hysteresis.pct|, the f1 data point
  LinearFit f3_flexion, f3_extension;  // V_qs = a V + b (slope a_x, intercept b_x)
};

struct QuasiStaticFit {
  LinearFit angle_of_v;              // angle = slope V + intercept: c9 = -slope, c10 = intercept
  LinearFit v_of_angle;              // V = s angle + k: sensitivity |s| [V/deg], linearity r2
  Eigen::VectorXd hold_v, hold_angle_deg;  // the settled hold averages
};

struct CalibrationResult {
  Calibration cal;
  QuasiStaticFit quasi_static;
  std::vector<VelocityTest> tests;
  ExpFit f1;
  LinearFit f2_a_flexion, f2_b_flexion, f2_a_extension, f2_b_extension;
  LinearFit f4_flexion, f4_extension;  // V_qs = slope V1 + intercept: c7 = slope, c8 = -intercept
  CombinedEquation eq11, eq12;
  std::vector<Segment> segments;
  Eigen::Index n_reference_rejected = 0;
};

/// Throws CalibrationError (a std::runtime_error) when the recording lacks what a fit needs, with
/// a message saying what is missing (e.g. "found 1 velocity test; f1 needs at least 2").
struct CalibrationError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

CalibrationResult calibrate(const Eigen::VectorXd& t_s, const Eigen::VectorXd& sensor_v,
                            const Eigen::VectorXd& reference_v, const Eigen::VectorXd& angle_ref_deg,
                            const CalibrationSettings& s = {});

/// eq. (11)/(12) in the paper's printed form, e.g.
/// "alpha_f = (-1.255 e^(-3.494 w) - 46.078) Vmeas + 5.84 e^(-3.494 w) + 199.149".
std::string format_combined_equation(const CombinedEquation& eq, Direction d);

}  // namespace pof::core
