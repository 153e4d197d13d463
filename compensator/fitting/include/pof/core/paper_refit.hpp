#pragma once
// The paper's model structure (table 2, f1-f5) refitted to one recording in the voltage domain:
// every coefficient that the forward model can tell apart, by Levenberg-Marquardt on
// v - model_voltage(m, angle, w, direction), started from the calibration procedure's result
// (calibration.hpp). `pof gap` uses it as its baseline, so a sensor of the paper's structure with
// its own coefficients leaves no gap (docs/gap.md, section 1).
//
// Identifiable parameters. Moving, the model voltage is (model.hpp, inverse of f3, f4, f5)
//   v = ((V2 + c8)/c7 - c5 h - c6) / (c3 h + c4),  V2 = (c10 - angle)/c9,  h = c1 e^{c2 |w|}
// which depends on c7, c8 only through c7 c3, c7 c4, c7 c5 and c8 - c7 c6 (per direction), and on
// c1 only through c1 c3, c1 c5 (both directions). So c1, c7 and c8 stay at their starting values
// and the 11 others are fitted: c2, c9, c10, and c3..c6 of each direction (kRefitParameters).
#include <array>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "pof/core/model.hpp"

namespace pof::core {

inline constexpr int kRefitParameters = 11;

/// Names of the refitted parameters, in gradient order ("c2", "c9", "c10", "flexion.c3", ...).
extern const std::array<std::string_view, kRefitParameters> kRefitParameterNames;

/// The refitted parameters of m, in gradient order.
std::array<double, kRefitParameters> refit_parameters(const ModelCoefficients& m);
/// m with the refitted parameters replaced by p (c1, c7, c8 kept).
ModelCoefficients with_refit_parameters(ModelCoefficients m, const std::array<double, kRefitParameters>& p);

/// model_voltage(m, angle, |w|, d) and its gradient in the refitted parameters (analytic).
double model_voltage_gradient(const ModelCoefficients& m, double angle_deg, double speed_rad_s, Direction d,
                              double* gradient /* kRefitParameters values */);

/// The f3-f4 chain undoes a hysteresis of a few percent, so its gain dV2/dV = c7 (c3 h + c4) stays
/// near 1 (table 2: 1.01-1.04 at every speed). A structure whose gain leaves
/// [kChainGainMin, kChainGainMax] at some speed reads the voltage there twice too steeply or too
/// flatly: a fit may find one (c3 and c4 nearly collinear when c2 |w| is small move far and
/// opposite, c2 compensating), and online, where |w| is an estimate, its angle runs away.
inline constexpr double kChainGainMin = 0.5;
inline constexpr double kChainGainMax = 2.0;

/// Whether m's chain gain is within [kChainGainMin, kChainGainMax] in both directions at every
/// speed in [0, max_speed_rad_s] (it is monotone in the speed: the ends suffice), and c9, c1 and
/// every coefficient finite with c9 != 0.
bool chain_admissible(const ModelCoefficients& m, double max_speed_rad_s);

struct PaperRefit {
  ModelCoefficients model;
  double rms_before_v = 0, rms_after_v = 0;  // over the rows used
  int iterations = 0;
  bool converged = false;
};

/// Levenberg-Marquardt from m0 on every `stride`-th scan. angle [deg], speed |w| [rad/s] and
/// direction per scan; v the normalised voltage. A step that would take the chain gain
/// c7 (c3 h + c4) out of [kChainGainMin, kChainGainMax] on a row used is refused.
PaperRefit refit_paper_model(const ModelCoefficients& m0, const Eigen::VectorXd& angle_deg,
                             const Eigen::VectorXd& speed_rad_s, const std::vector<Direction>& dir,
                             const Eigen::VectorXd& v, int stride = 4);

}  // namespace pof::core
