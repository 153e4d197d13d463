#pragma once
// Model steps (docs/calibration.md, "Model steps"): eqs. (11)/(12) at w -> 0 do not meet f5, so a
// sensor that follows the paper's model steps at every start, stop and reversal, against the
// motion. Read as motion, such a step turns the direction the wrong way for ~0.1 s. A step of the
// size and sign the calibration predicts for a change of direction, seen in the mean of the newest
// block of f5 angles against the line through the 3 blocks before, names the new direction at once
// and is taken out of the velocity window; a sensor without such steps never matches.
//
// Only with the paper model and the sensor as velocity source (CompensatorSettings::model_steps).
// Threading: used from one thread. Only the constructor allocates; nothing else allocates or throws.
#include <cstdint>
#include <vector>

#include "pof/core/model.hpp"
#include "pof/core/velocity_window.hpp"

namespace pof::core {

struct CompensatorSettings;

class StepDetector {
 public:
  StepDetector() = default;  // off
  /// On when s.model_steps asks for it and a block and the 3 before it fit a window of
  /// window_scans; throws std::invalid_argument on step settings that cannot work.
  StepDetector(const ModelCoefficients& model, double velocity_min_rad_s, const CompensatorSettings& s,
               int window_scans);

  /// Looks at the newest block of the (full) window in direction `phase`: returns the direction a
  /// predicted step names (the step then taken out of the window), else `phase`.
  Direction detect(VelocityWindow& window, Direction phase) noexcept;
  /// Once per scan, before detect(): counts down hold().
  void tick() noexcept {
    if (hold_ > 0) --hold_;
  }
  /// The window restarts: the offset and the hold go; the statistic's spread (a property of the
  /// sensor and converter) stays.
  void clear() noexcept {
    offset_ = 0;
    hold_ = 0;
  }

  [[nodiscard]] bool enabled() const noexcept { return m_ > 0; }
  /// The steps taken out since the last clear() [deg]: subtract from every angle pushed.
  [[nodiscard]] double offset() const noexcept { return offset_; }
  /// Scans until the window no longer holds angles from before the last step (0: none).
  [[nodiscard]] int hold() const noexcept { return hold_; }

 private:
  // The f5-angle step [deg] the paper model predicts for a change of direction from `from` to `to`
  // at angle [deg] (both branches at the lowest calibrated speed; f5 in holds).
  double predicted_step(double angle, Direction from, Direction to) const noexcept;

  ModelCoefficients model_;
  double velocity_min_rad_s_ = 0;
  double tolerance_ = 0.4, min_snr_ = 6, min_deg_ = 0.4;
  int n_ = 0;  // the velocity window [scans]
  int m_ = 0;  // block length [scans], 0 = off
  std::vector<double> scratch_;  // the newest 4 blocks, newest first
  double offset_ = 0;
  double stat_var_ = 0;  // mean square of the step statistic
  std::int64_t stat_count_ = 0;  // scans it has seen
  int hold_ = 0;
};

}  // namespace pof::core
