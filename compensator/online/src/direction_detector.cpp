#include "pof/core/direction_detector.hpp"

#include <cmath>

#include "pof/core/compensator.hpp"
#include "pof/core/units.hpp"

namespace pof::core {

DirectionDetector::DirectionDetector(const CompensatorSettings& s, int reversal_scans)
    : scan_rate_hz_(s.scan_rate_hz),
      move_rad_s_(s.move_rad_s),
      hold_rad_s_(s.hold_rad_s),
      reversal_rad_s_(s.reversal_rad_s),
      reversal_scans_(reversal_scans) {}

double DirectionDetector::to_rad_s(double slope) const noexcept { return slope * scan_rate_hz_ * kRadPerDeg; }

Direction DirectionDetector::update(const VelocityWindow& window, double w, Direction stepped, int step_hold) noexcept {
  const bool fast = reversal_scans_ > 0;
  const double ws = fast ? to_rad_s(window.recent_slope(reversal_scans_)) : 0.0;
  if (!window.full()) {
    phase_ = Direction::kHold;  // a half-filled window is too noisy to decide a direction
  } else if (stepped != phase_) {
    phase_ = stepped;  // the step the model predicts for this change of direction
  } else if (step_hold > 0) {
    // A step decided the direction; the window still holds angles from before it. From half a
    // window after it, the slope of the scans since the step alone (noise 0.003 rad/s at 0.1 deg,
    // 200 Hz) may name a movement beyond reversal_rad_s in either sense: a stop taken where the
    // knee turned, or moved on with a start step too small to see.
    if (const int since = window.size() - step_hold; since >= window.size() / 2) {
      const double ws_since = to_rad_s(window.recent_slope(since));
      if (ws_since > reversal_rad_s_) phase_ = Direction::kFlexion;
      else if (ws_since < -reversal_rad_s_) phase_ = Direction::kExtension;
    }
  } else if (phase_ == Direction::kHold) {
    if (w > move_rad_s_) phase_ = Direction::kFlexion;
    else if (w < -move_rad_s_) phase_ = Direction::kExtension;
  } else if (std::abs(w) < hold_rad_s_ && (!fast || std::abs(ws) < reversal_rad_s_)) {
    phase_ = Direction::kHold;
  } else if (phase_ == Direction::kFlexion &&
             (fast ? (ws < -reversal_rad_s_ || (w < -move_rad_s_ && ws < 0)) : w < -move_rad_s_)) {
    phase_ = Direction::kExtension;
  } else if (phase_ == Direction::kExtension &&
             (fast ? (ws > reversal_rad_s_ || (w > move_rad_s_ && ws > 0)) : w > move_rad_s_)) {
    phase_ = Direction::kFlexion;
  }
  return phase_;
}

}  // namespace pof::core
