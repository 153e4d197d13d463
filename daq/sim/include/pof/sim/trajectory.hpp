#pragma once
// The knee: a motor + harmonic drive following the commanded trajectory of a scenario under
// velocity and acceleration limits. Used by Simulator; on its own it is the benchmark baseline.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "pof/sim/scenario.hpp"

namespace pof::sim {

struct KneeState {
  double angle_deg = 0;             // harmonic-drive output = fibre bend angle (ground truth)
  double velocity_deg_s = 0;        // signed, + = flexion
  double acceleration_deg_s2 = 0;
  double commanded_deg = 0;         // where the controller is heading
  int segment = -1;                 // index into Scenario::trajectory (-1 before the first)
};

class Trajectory {
 public:
  /// Compiles the segments into moves and holds; random per-cycle variation (kSubject) is drawn
  /// here from `seed`. Throws pof::ConfigError if the trajectory is empty.
  Trajectory(const Scenario& s, std::uint64_t seed, double dt_s);

  /// Advances one time step and returns the new state. Never allocates or throws.
  const KneeState& step();
  [[nodiscard]] const KneeState& state() const { return st_; }
  /// True once the last step is done (never in loop mode).
  [[nodiscard]] bool finished() const { return finished_; }
  /// Duration [s] of one pass if every move ran at its cruise speed (a lower bound, for sizing).
  [[nodiscard]] double nominal_duration_s() const { return nominal_duration_s_; }

  enum class StepKind : int { kMove, kHold, kGait };
  struct Step {
    StepKind kind = StepKind::kHold;
    int segment = 0;
    double target_deg = 0;      // kMove
    double speed_deg_s = 0;     // kMove cruise speed
    std::int64_t ticks = 0;     // kHold, kGait: duration in time steps
    double min_deg = 0, stance_deg = 0, swing_deg = 0, period_s = 1;  // kGait
  };
  [[nodiscard]] const std::vector<Step>& steps() const { return steps_; }

 private:
  void start_step();
  void gait_command(const Step& g, double t, double& pos, double& vel) const;

  std::vector<Step> steps_;
  double dt_;
  double vmax_, amax_, kp_;
  bool loop_;
  KneeState st_;
  std::size_t idx_ = 0;
  std::int64_t tick_in_step_ = 0;
  bool finished_ = false;
  double nominal_duration_s_ = 0;
};

}  // namespace pof::sim
