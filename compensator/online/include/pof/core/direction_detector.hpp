#pragma once
// The direction of movement the paper's branches need (eqs. (11)/(12) in flexion and extension,
// f5 in holds), decided from the velocity window with a dead band (docs/calibration.md, "Online
// compensation", step 4):
//   - a hold becomes a movement above move_rad_s, a movement a hold below hold_rad_s;
//   - with the reversal window on, its shorter slope flips flexion <-> extension as soon as it
//     clearly sees the opposite sense, the long window flips only when it agrees, and a hold needs
//     both quiet (the long window passes through zero at every reversal);
//   - a model step the step detector took decides the direction at once, and while the window
//     still holds angles from before it only the scans since the step may name a movement.
//
// Threading: used from one thread. Never allocates, never throws.
#include "pof/core/model.hpp"
#include "pof/core/velocity_window.hpp"

namespace pof::core {

struct CompensatorSettings;

class DirectionDetector {
 public:
  DirectionDetector() = default;
  /// reversal_scans: the reversal window's length [scans], 0 = off.
  DirectionDetector(const CompensatorSettings& s, int reversal_scans);

  /// This scan's direction from the window's velocity w [rad/s] and the direction a model step
  /// named (`stepped`, the current one if none); step_hold > 0 while the window still holds angles
  /// from before a step (StepDetector::hold()). A window that is not full is a hold.
  Direction update(const VelocityWindow& window, double w, Direction stepped, int step_hold) noexcept;

  [[nodiscard]] Direction phase() const noexcept { return phase_; }
  void clear() noexcept { phase_ = Direction::kHold; }

 private:
  double to_rad_s(double slope_deg_per_scan) const noexcept;

  Direction phase_ = Direction::kHold;
  double scan_rate_hz_ = 200, move_rad_s_ = 0.010, hold_rad_s_ = 0.006, reversal_rad_s_ = 0.03;
  int reversal_scans_ = 0;
};

}  // namespace pof::core
