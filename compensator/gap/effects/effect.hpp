#pragma once
// The candidate effects of `pof gap`, one file each in this folder (docs/gap.md, section 3). An
// effect is a parametric term added to the model voltage, linear in its coefficients once its
// nonlinear parameter theta is fixed; theta is chosen on a grid. Kinematic effects (time delay,
// backlash) change the angle the sensor sees instead and have no columns.
//
// The identifiers come from the one catalogue, pof/core/effects.hpp (shared with the simulator and the
// compensator). The basis functions here are the ones the compensator evaluates online
// (docs/calibration.md, "[gap]"): a coefficient written to model.toml is volts per unit of the
// basis, in the calibration's normalised voltage.
#include <cmath>
#include <optional>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "pof/core/dynamic_model.hpp"
#include "pof/core/effects.hpp"
#include "pof/core/gap_terms.hpp"
#include "pof/core/model.hpp"
#include "pof/gap/signals.hpp"

namespace pof::gap {

/// What every effect may use: the recording and the baseline model it is added to.
struct Context {
  const Signals* s = nullptr;
  core::ModelCoefficients m;  // the paper's structure refitted to this recording (the baseline unless dyn is set)
  double duration_s = 0;
  double max_speed_rad_s = 0;  // the recording's largest |w| (where a moved structure must stay invertible)
  core::ModelCoefficients origin;  // the baseline as fitted, before any move (how far m may move)
  double angle_min_deg = 0, angle_max_deg = 90;  // the recording's angle range
  // The dynamic model when it is the baseline (docs/gap.md, section 1): its regressors are the
  // structure columns and its voltage v0; m still gives f5 and the sensitivity effects scale by.
  std::optional<core::DynamicModel> dyn, dyn_origin;  // now, and as fitted before any move
  double move_limit_deg = 0;  // how far a move may take the baseline (structure_move_limit, set with the origin)
};

enum class Acts : int {
  kSensor,    // a voltage term (columns)
  kDelay,     // theta is the delay of the angle the sensor sees [s]
  kBacklash,  // theta is the belt play between the reference and the joint [deg]
};

struct EffectDef {
  core::Effect id;
  std::string_view meaning;   // one line: the physical mechanism
  Acts acts = Acts::kSensor;
  int linear = 1;             // columns (linear coefficients)
  std::string_view theta_key{};  // the physical parameter theta reports as ("" if none), e.g. "tau_s"
  double theta_scale = 1;
  /// The physical parameter whose zero means "no effect" (e.g. "delay_ms"), or "": an effect is
  /// only named if its jackknife tells that magnitude apart from zero (|x| > 2 SE).
  std::string_view magnitude_key{};     // reported value = theta * theta_scale (e.g. delay in ms)
  bool refit_theta = false;   // re-chosen on all data after every acceptance (docs/gap.md, section 4)
  /// The grid of theta; resid is the current held-out residual [V] (used by effects that look at
  /// its spectrum). One value 0 for an effect without theta.
  std::vector<double> (*grid)(const Context&, const Eigen::VectorXd& resid) = nullptr;
  /// Extra grid values around the coarse grid's best value (chosen on all data), or null: the
  /// per-fold choice then runs over both. A coarse grid alone would leave part of an effect in the
  /// residual for a candidate with more columns to take (creep at tau 4 s between grid values 3.75
  /// and 4.88 s is fitted better by five relaxation terms than by the nearest single one).
  std::vector<double> (*refine)(double best, const Context&) = nullptr;
  /// The n x linear columns at theta (volts per unit of coefficient); null for kinematic effects.
  Eigen::MatrixXd (*columns)(double theta, const Context&, const Kinematics&) = nullptr;
  /// For an effect whose columns at every theta are some of one fixed set (viscoelastic_relaxation:
  /// two of its 17 time constants), the set and which of its columns theta takes, in the order
  /// `columns` gives them; null: none. The search then forms the set's cross products once per
  /// state instead of once per grid value (the same sums, taken from one larger product).
  Eigen::MatrixXd (*column_set)(const Context&, const Kinematics&) = nullptr;
  std::vector<Eigen::Index> (*columns_in_set)(double theta) = nullptr;
  /// Physical parameters from theta and the coefficients b (calibration volts per unit of basis).
  nlohmann::json (*physical)(double theta, const Eigen::VectorXd& b, const Context&) = nullptr;
  /// Why the effect cannot be identified on this recording, or "" (e.g. a constant source power).
  std::string_view (*not_identifiable)(const Context&) = nullptr;
  /// Why fitted parameters (with their "_se") are not physical, or "" (e.g. a relaxation spectrum
  /// with gains of both signs). An inadmissible fit is not named; the next candidate is tried.
  std::string (*inadmissible)(const nlohmann::json& parameters) = nullptr;
  /// For an effect whose columns are slow random signals (the reference's level), > 0: it is only
  /// named if it also explains, on held-out blocks, the residual's part faster than this [s] (the
  /// residual and its columns less their centred mean over this span). Two slowly wandering
  /// series correlate by chance, far beyond what their sample size suggests (Granger and Newbold
  /// 1974, "Spurious regressions in econometrics", J. Econometrics 2: 111-120), and a slow
  /// leftover (a relaxation's tail, a drift) is one; a coupling is there at every time scale the
  /// source's power changes on (docs/gap.md, section 4, "Slow random columns").
  double fast_part_s = 0;
  /// The simpler effect this one generalises (viscoelastic_relaxation: creep), if any. The general
  /// one is only named when it beats the simpler one by the acceptance rule itself (docs/gap.md,
  /// section 4), as if it were a further step on top of it.
  std::optional<core::Effect> generalises{};
  /// How the term is written to model.toml for the compensator (docs/calibration.md, "[gap]"):
  /// whether theta is (relaxation's theta only indexes its pair, written as time_constants_s), and
  /// how many coefficients the file's basis has; beyond `linear` they are written as 0
  /// (rate_dependent_hysteresis: the paper-hysteresis scale, which the refitted baseline carries).
  bool theta_in_file = true;
  int file_coefficients = 0;  // 0: linear
  /// Writes the fixed basis constants model.toml holds beside the coefficients into the term
  /// (memory_hysteresis: thresholds_deg or relay_centres_deg; viscoelastic_relaxation:
  /// time_constants_s), or null: none.
  void (*write_basis)(double theta, const Context&, core::GapTerm& term) = nullptr;
  /// For an effect whose number of columns depends on the recording (drift: its degree follows the
  /// recording's length), that number; null: `linear`. Read through linear_columns().
  int (*linear_of)(const Context&) = nullptr;
};

/// The number of columns (linear coefficients) of an effect on this recording.
inline int linear_columns(const EffectDef& def, const Context& cx) {
  return def.linear_of != nullptr ? def.linear_of(cx) : def.linear;
}

/// The definition of an effect (every core::Effect has one).
const EffectDef& effect_def(core::Effect e);

/// The shared pieces several effects are built from.
namespace basis {
/// x - angle, x the angle low-passed with time constant tau [s] (x_0 = angle_0): the state of a
/// standard linear solid, i.e. one Prony term of viscoelastic relaxation [deg].
Eigen::VectorXd relaxation(const Eigen::VectorXd& angle, double dt, double tau_s);
/// The quasi-static voltage of the baseline at each scan's angle (f5 inverted) [V].
Eigen::VectorXd quasi_static_v(const Context& cx, const Kinematics& k);
/// A log-spaced grid of n values from a to b.
std::vector<double> log_grid(double a, double b, int n);
/// best * 2^(j/16), j = -4..4 without 0: a log grid refined to 4.4 % steps around best.
std::vector<double> log_refine(double best);
/// best + j * step, j = -9..9 without 0, keeping values > min.
std::vector<double> linear_refine(double best, double step, double min);
/// An angle-like coefficient in volts per degree, as the angle error it causes [deg per deg].
/// (|c9| of the baseline as it stands: the structure's coefficients move during the search.)
inline double as_angle_error(double v_per_unit, const Context& cx) { return -v_per_unit * std::abs(cx.m.c9); }
}  // namespace basis

}  // namespace pof::gap
