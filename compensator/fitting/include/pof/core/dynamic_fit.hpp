#pragma once
// Identification of the dynamic model (dynamic_model.hpp) from the recording the paper's protocol
// already makes: quasi-static steps with holds (the line, the memory at rest, the relaxation over
// each hold) and the table-1 constant-velocity cycles (the loop and its rate dependence). No extra
// protocol is needed.
//
// With the thresholds r_i, the Prony time constants tau_j, the rate gain kappa and the bend lag
// tau_b fixed, the model is linear in its coefficients: the bend lag, operators, Prony states and
// speed filter are run over the reference angle (potentiometer), exactly as the online inverse
// runs them over its own angle,
// and the normalised voltage is regressed on
//     [ x^0 .. x^d | phi(w) S_1 .. phi(w) S_n | m_1 .. m_k ]
// by least squares with the operator weights constrained to one sign (nnls_normal, both signs
// tried). The structure (d, n, k, kappa, tau_b) is chosen by blocked cross-validation: K contiguous
// blocks cut at holds (as `pof gap` does, so no movement is split), each held out in turn, the
// coefficients fitted on the others. Candidates whose inverse would not be monotone over the
// search range are refused. When that leaves the best admissible structure much worse than the
// best refused one (a fibre whose output runs backwards after a reversal), the search runs again
// with each fit held to the invertibility rule (a constrained least squares) instead of dropping
// the operators, and the result says how far the unconstrained fit runs backwards.
// docs/calibration.md, "The dynamic model".
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "pof/core/dynamic_model.hpp"
#include "pof/core/estimator_noise.hpp"
#include "pof/core/segmentation.hpp"

namespace pof::core {

struct DynamicFitSettings {
  std::vector<int> degrees{1, 3, 5};                 // quasi-static polynomial degrees tried
  std::vector<int> operator_counts{0, 3, 5, 8, 12};  // stop operators tried
  std::vector<int> prony_counts{0, 1, 2, 3, 4};      // Prony terms tried
  std::vector<double> rate_gains_s_per_rad{-4, -2, -1, -0.5, 0, 0.5, 1, 2};  // kappa tried
  double min_threshold_deg = 0.5;       // smallest operator threshold (above angle noise)
  double max_threshold_fraction = 0.4;  // largest threshold as a fraction of the angle span
  double min_tau_s = 0.5, max_tau_s = 60;  // Prony time constants spread log-uniformly in here
  double speed_filter_s = 0.1;
  // Bend lags tau_b tried [s] in every round of fit_dynamic's search, besides 0 (no lag), then
  // refined around the best; refined lags may leave this range.
  std::vector<double> bend_lags_s{0.02, 0.04, 0.08, 0.16, 0.32};
  double lag_window_s = 0.12;  // the lag inverse's window (dynamic_model.hpp, LagInverse)
  int folds = 5;
  int max_search_rounds = 4;  // rounds (>= 1) of the coordinate descent over the structure (fit_dynamic)
  // The search is run again under the invertibility rule when the best admissible structure's
  // held-out error exceeds this multiple of the best refused one's (docs/calibration.md,
  // "The dynamic model": 0.67-1.01 measured on ordinary simulated fibres, 13 on one that runs backwards).
  double constrain_above_ratio = 1.5;
  double fit_rate_hz = 50;              // rows of the normal equations are decimated to about this
  SegmentationSettings segmentation;
  double min_hold_s = 3.0;              // a hold at least this long counts for the "needs holds" check
  EstimatorNoiseSettings estimator;
};

/// One structure tried, with its cross-validated error.
struct DynamicCandidate {
  int degree = 0, n_operators = 0, n_prony = 0;
  double rate_gain_s_per_rad = 0;
  double bend_lag_s = 0;
  double cv_rmse_v = 0;      // held-out voltage RMSE [V]
  double cv_rmse_deg = 0;    // the same over the quasi-static sensitivity [deg]
  bool admissible = true;    // false: some fold's fit would not be invertible
  bool constrained = false;  // each fold fitted under the invertibility rule (the constrained search)
};

struct DynamicFitResult {
  DynamicModel model;                 // the chosen structure refitted on the whole recording
  DynamicCandidate chosen;
  std::vector<DynamicCandidate> candidates;
  double train_rmse_v = 0, train_rmse_deg = 0;
  double sensitivity_v_per_deg = 0;   // |dV/dtheta| of the least-squares line through the data
  std::vector<Eigen::Index> fold_begin, fold_end;  // the held-out blocks [begin, end)
  // When the constrained search ran (DynamicFitSettings::constrain_above_ratio): the best refused
  // structure, and what its fit on the whole recording, without the invertibility rule, says of
  // the sensor at rest after a reversal: the travel over which the output runs backwards (0: it
  // does not, the rule's margin refused it), and the span of angles one voltage stands for there,
  // the travel until the output is back at its reversal value (the error a reading of the voltage
  // alone can make). docs/calibration.md, "The dynamic model".
  std::optional<DynamicCandidate> unconstrained;
  double backwards_deg = 0, backwards_ambiguity_deg = 0;
  Eigen::Index n_used = 0;            // scans in the regression
  // The angle estimator's noises (estimator_noise.hpp), or why they could not be identified.
  std::optional<EstimatorNoise> estimator;
  std::string estimator_note;
};

struct DynamicFitError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Thresholds and time constants of a structure (the grids fit_dynamic tries).
std::vector<double> operator_thresholds(int n, double min_deg, double max_deg);
std::vector<double> prony_time_constants(int k, double min_s, double max_s);

/// K contiguous blocks of [0, n) whose boundaries are moved to the nearest hold sample, so that
/// no movement is split. Used for both models' held-out errors.
void hold_blocks(const std::vector<Segment>& segments, Eigen::Index n, int folds, std::vector<Eigen::Index>& begin,
                 std::vector<Eigen::Index>& end);

/// v_norm: the reference-normalised sensor voltage (NaN where unusable); angle_ref_deg: the
/// reference angle (NaN where unusable). Throws DynamicFitError saying what the recording lacks
/// (holds, both directions) or that no candidate could be inverted.
DynamicFitResult fit_dynamic(const Eigen::VectorXd& t_s, const Eigen::VectorXd& v_norm, const Eigen::VectorXd& angle_ref_deg,
                             const DynamicFitSettings& s = {});

/// The chosen structure of `fit` refitted with each of its blocks held out in turn (the same
/// per-block normal equations as its cross-validation): one model per block, none where the
/// block is empty or the refit would not be invertible. For held-out tests (model_selection.hpp).
std::vector<std::optional<DynamicModel>> fold_models(const DynamicFitResult& fit, const Eigen::VectorXd& t_s,
                                                     const Eigen::VectorXd& v_norm, const Eigen::VectorXd& angle_ref_deg,
                                                     const DynamicFitSettings& s = {});
/// The linear coefficients of a model, in the order of its regressors: the polynomial's degree + 1,
/// then one weight per stop operator, then one gain per Prony term.
Eigen::VectorXd dynamic_coefficients(const DynamicModel& m);
/// m with its linear coefficients replaced by b (the order of dynamic_coefficients).
DynamicModel with_dynamic_coefficients(DynamicModel m, const Eigen::VectorXd& b);
/// The regressors of m's structure (thresholds, time constants, rate gain and bend lag fixed) over
/// a whole angle history at scan rate fs: one row per scan, the columns fit_dynamic regresses the
/// voltage on, so forward_dynamic = regressors x dynamic_coefficients (a row of zeros where the
/// angle is not finite; the operators hold their state there). `pof gap`'s design when the dynamic
/// model is its baseline.
Eigen::MatrixXd dynamic_regressors(const DynamicModel& m, const Eigen::VectorXd& angle_deg, double scan_rate_hz);
/// Whether the online inverse exists for every state of m's memory: the quasi-static slope
/// dominates the opposing operators and the Prony terms' instant slope over the search bracket
/// (the rule fit_dynamic refuses candidates by).
bool dynamic_invertible(const DynamicModel& m, double scan_rate_hz);

/// The forward model over a whole angle history at scan rate fs: V for each scan (NaN angles hold
/// the previous one). For plots and tests.
Eigen::VectorXd forward_dynamic(const DynamicModel& m, const Eigen::VectorXd& angle_deg, double scan_rate_hz);

}  // namespace pof::core
