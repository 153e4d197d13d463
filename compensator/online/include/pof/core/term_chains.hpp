#pragma once
// The [gap] effect terms inside the online compensator (docs/calibration.md, "`[gap]`: effect terms
// and how the compensator applies them", steps 1-7): two copies of the same terms (GapCorrector).
//
//   quiet chain      driven by f5 of the voltage after its own terms (the quiet angle), which
//                    decides nothing and goes through no branch: the velocity and the direction are
//                    estimated on it; on the paper chain it also gives the published voltage.
//   published chain  driven by the published angle (the active model's inverse): notches the
//                    voltage, and on the dynamic model gives the terms' voltage for the inverse;
//                    undoes the delay and the play on the inverse's angle, with the extrapolation's
//                    slope and the play's side of the quiet chain.
//
// Each chain's voltage at this scan's angle is solved (solve_voltage): A = model^-1(v - g(A)) on
// the model linearised at the previous angle, the terms exact (step 2 there).
//
// Threading: used from one thread. Only the constructor allocates; nothing else allocates or throws.
#include <limits>
#include <optional>

#include "pof/core/dynamic_model.hpp"
#include "pof/core/gap_terms.hpp"
#include "pof/core/model.hpp"

namespace pof::core {

struct Calibration;

class TermChains {
 public:
  TermChains() = default;  // no terms: active() false
  /// cal.gap must hold terms the compensator can apply at scan_rate_hz (gap_problems() empty);
  /// `dynamic`: the dynamic model is the active one.
  TermChains(const Calibration& cal, double scan_rate_hz, bool dynamic);

  [[nodiscard]] bool active() const noexcept { return active_; }

  /// A new scan: the quiet chain's kinematics are not yet this scan's.
  void begin_scan() noexcept { quiet_committed_ = false; }
  /// The normalised voltage with every periodic_interference frequency notched out.
  double filter(double v) noexcept { return published_.terms.filter(v); }
  /// f5 of v with the quiet chain's terms (their voltage *g) taken off: the velocity source's angle.
  double quiet_angle(double v, double reference_v, double* g) const noexcept;
  /// The published angle's terms voltage at this scan [V], with velocity w and direction d:
  /// the quiet chain's terms at quiet angle y on the paper chain; the published chain solved for
  /// this scan's angle on the dynamic model or without a quiet angle; plus the quiet chain's
  /// acceleration term there (it lives in the quiet chain alone, step 4).
  double published_voltage(double v, double reference_v, double y, double w, Direction d) const noexcept;
  /// The published chain's voltage alone (no velocity: the compensator falls back to a hold).
  double published_chain_voltage(double v, double reference_v, double w, Direction d) const noexcept;
  /// Commits this scan's quiet angle and the voltage f5 inverted (v - g) to the quiet chain, with
  /// the direction the compensator decided (a positive delay is not extrapolated in a hold on the
  /// paper chain, step 6).
  void commit_quiet(double angle, double u, double reference_v, Direction phase) noexcept;
  /// A scan the quiet chain does not commit: the windows that would span it restart.
  void skip_quiet() noexcept;
  /// The quiet chain's angle was not finite: its windows restart.
  void interrupt_quiet() noexcept { quiet_.terms.interrupt(); }
  /// An unusable scan: both chains' windows restart (the memories stay).
  void interrupt() noexcept;
  /// The reference-equivalent angle of the inverse's fibre angle (its voltage v): the delay and the
  /// play undone (steps 5-6).
  double reference_angle(double angle, double v, double reference_v) noexcept;
  /// Lost scans: everything restarts.
  void reset() noexcept;

 private:
  // The state of one chain of terms over one angle: the terms, the angle they were last advanced
  // to and the voltage inverted then.
  struct Chain {
    GapCorrector terms;
    double angle = std::numeric_limits<double>::quiet_NaN();  // the previous scan's angle [deg]
    double u = std::numeric_limits<double>::quiet_NaN();      // the voltage inverted then [V]
    void restart() noexcept {
      terms.reset();
      angle = u = std::numeric_limits<double>::quiet_NaN();
    }
  };
  // A chain's voltage at this scan's angle, with velocity w and direction d: solved from its
  // previous angle (f5 of v for the first) on the model linearised there (slope dA/dv `slope`).
  double solve_voltage(const Chain& c, double v, double reference_v, double w, Direction d, double slope) const noexcept;
  // dA/dv [deg/V] of the active model at angle [deg] with velocity w and direction d.
  double model_slope(double angle, double w, Direction d) const noexcept;

  bool active_ = false;
  bool dynamic_ = false;
  ModelCoefficients model_;
  std::optional<DynamicModel> dynamic_model_;
  Chain published_, quiet_;
  // The dynamic model with a play: the model's inverse of the quiet chain's voltage, the angle the
  // play's side is decided on. f5 (the quiet angle) lacks the structure's relaxation and stop
  // operators; a play fed it falls back as the fibre relaxes in every hold (step 6).
  DynamicInverter play_inverter_;
  bool play_inverse_ = false;
  bool quiet_committed_ = false;  // the quiet chain has this scan's angle (its kinematics are current)
  // The terms' slope dg/dA is a difference over this step [deg] (their bases are smooth or
  // piecewise linear in A: stop and play operators).
  static constexpr double kSlopeStepDeg = 1e-3;
  // 1 + s g' below this (the terms cancelling most of the model's slope) is held here.
  static constexpr double kMinDivisor = 0.25;
  // The solve: at most this many Newton steps to a bracket, and as many regula falsi steps within
  // it, down to kTolDeg. Piecewise linear terms close in a few; the bound keeps a scan's work fixed.
  static constexpr int kSearchSteps = 12;
  static constexpr double kTolDeg = 1e-6;
};

}  // namespace pof::core
