// The knee's motion: the commanded trajectory compiled into moves, holds and gait tracking, run
// by a time-optimal controller under the drive's velocity and acceleration limits.
#include "pof/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "pof/base/errors.hpp"
#include "pof/core/units.hpp"
#include "pof/sim/rng.hpp"

namespace pof::sim {

namespace {
using pof::core::kDegPerRad;
constexpr std::uint64_t kStreamSubject = 101;
// random_moves segment i draws from stream kStreamRandomMoves + i: adding or changing one such
// segment does not change the draws of the subject segments or of another random_moves segment.
constexpr std::uint64_t kStreamRandomMoves = 201;

// Periodic bump (von Mises shape) of width sigma (fraction of a period) centred on c, peak 1.
double bump(double phase, double c, double sigma, double& dbump_dphase) {
  const double kappa = 1.0 / (2 * std::numbers::pi * sigma * 2 * std::numbers::pi * sigma);
  const double a = 2 * std::numbers::pi * (phase - c);
  const double b = std::exp(kappa * (std::cos(a) - 1.0));
  dbump_dphase = -b * kappa * std::sin(a) * 2 * std::numbers::pi;
  return b;
}
// Knee flexion over a gait cycle (Perry's gait phases, simplified): a loading-response peak at
// ~13 % of the cycle and the swing peak at ~72 %.
constexpr double kStanceCentre = 0.13, kStanceWidth = 0.06, kSwingCentre = 0.72, kSwingWidth = 0.10;
}  // namespace

Trajectory::Trajectory(const Scenario& s, std::uint64_t seed, double dt_s)
    : dt_(dt_s),
      vmax_(s.knee.max_velocity_rad_s * kDegPerRad),
      amax_(s.knee.max_acceleration_rad_s2 * kDegPerRad),
      kp_(s.knee.tracking_gain_per_s),
      loop_(s.loop) {
  if (s.trajectory.empty()) throw pof::ConfigError(s.source + ": key 'trajectory': expected at least one segment");
  Rng rng(seed, kStreamSubject);
  auto ticks = [&](double seconds) { return static_cast<std::int64_t>(std::llround(seconds / dt_)); };
  double pos = s.knee.start_deg;  // planned position, for nominal duration only
  auto move = [&](int seg, double target, double speed_rad_s) {
    Step st;
    st.kind = StepKind::kMove;
    st.segment = seg;
    st.target_deg = target;
    st.speed_deg_s = std::min(speed_rad_s * kDegPerRad, vmax_);
    steps_.push_back(st);
    nominal_duration_s_ += std::abs(target - pos) / st.speed_deg_s;
    pos = target;
  };
  auto hold = [&](int seg, double seconds) {
    if (seconds <= 0) return;
    Step st;
    st.kind = StepKind::kHold;
    st.segment = seg;
    st.ticks = ticks(seconds);
    steps_.push_back(st);
    nominal_duration_s_ += seconds;
  };

  for (std::size_t i = 0; i < s.trajectory.size(); ++i) {
    const Segment& g = s.trajectory[i];
    const int seg = static_cast<int>(i);
    switch (g.kind) {
      case SegmentKind::kQuasiStatic: {
        // Paper section 2.2: 0 -> 90 deg in 5 deg steps, 10 s at each step.
        const int n = static_cast<int>(std::floor((g.to_deg - g.from_deg) / g.step_deg + 1e-9));
        move(seg, g.from_deg, g.move_velocity_rad_s);
        hold(seg, g.hold_s);
        for (int k = 1; k <= n; ++k) {
          move(seg, g.from_deg + k * g.step_deg, g.move_velocity_rad_s);
          hold(seg, g.hold_s);
        }
        if (g.descending) {
          for (int k = n - 1; k >= 0; --k) {
            move(seg, g.from_deg + k * g.step_deg, g.move_velocity_rad_s);
            hold(seg, g.hold_s);
          }
        }
        break;
      }
      case SegmentKind::kCycles:
      case SegmentKind::kSubject: {
        const bool subject = g.kind == SegmentKind::kSubject;
        move(seg, g.min_deg, g.move_velocity_rad_s);
        hold(seg, g.pause_s);
        for (double v : g.velocities_rad_s) {
          for (int c = 0; c < g.cycles_per_velocity; ++c) {
            // A subject changes the pace and the turning point of each stroke a little.
            double vf = v, ve = v, top = g.max_deg, bottom = g.min_deg;
            if (subject) {
              vf = v * std::max(0.2, 1.0 + g.velocity_jitter_rel * rng.normal());
              ve = v * std::max(0.2, 1.0 + g.velocity_jitter_rel * rng.normal());
              top = std::clamp(g.max_deg + g.amplitude_jitter_deg * rng.normal(), g.min_deg + 1, 95.0);
              bottom = std::clamp(g.min_deg + g.amplitude_jitter_deg * rng.normal(), -5.0, top - 1);
            }
            move(seg, top, vf);  // flexion
            hold(seg, g.pause_s);
            move(seg, bottom, ve);  // extension
            hold(seg, g.pause_s);
          }
        }
        break;
      }
      case SegmentKind::kGait: {
        Step st;
        st.kind = StepKind::kGait;
        st.segment = seg;
        st.min_deg = g.min_deg;
        st.stance_deg = g.stance_peak_deg;
        st.swing_deg = g.max_deg - g.min_deg;
        st.period_s = g.period_s;
        st.ticks = ticks(g.cycles * g.period_s);
        double p0 = 0, v0 = 0;
        gait_command(st, 0.0, p0, v0);
        move(seg, p0, g.move_velocity_rad_s);
        hold(seg, 1.0);
        steps_.push_back(st);
        nominal_duration_s_ += g.cycles * g.period_s;
        break;
      }
      case SegmentKind::kHold:
        if (g.has_angle) move(seg, g.angle_deg, g.move_velocity_rad_s);
        hold(seg, g.duration_s);
        break;
      case SegmentKind::kRandomMoves: {
        // Point-to-point moves as an operator or a subject makes them: a random target, a random
        // cruise speed, a random hold (0: the next move starts as soon as the knee has stopped).
        // With reversal_probability a move is abandoned part-way: the knee stops at 30-70 % of the
        // way and at once heads for a new target on the other side of where it turned.
        Rng r(seed, kStreamRandomMoves + i);
        auto uniform = [&r](double lo, double hi) { return lo + (hi - lo) * r.uniform(); };
        const double span = g.max_deg - g.min_deg;
        const double min_travel = std::min(2.0, 0.25 * span);  // no trivial moves
        double at = std::clamp(pos, g.min_deg, g.max_deg);
        if (at != pos) move(seg, at, g.move_velocity_rad_s);  // into the range first
        for (int k = 0; k < g.moves; ++k) {
          double target = uniform(g.min_deg, g.max_deg);
          for (int tries = 0; tries < 16 && std::abs(target - at) < min_travel; ++tries) target = uniform(g.min_deg, g.max_deg);
          const double speed = uniform(g.min_velocity_rad_s, g.max_velocity_rad_s);
          // Always draw the reversal's numbers, so the sequence of targets does not depend on p.
          const double u_rev = r.uniform(), frac = uniform(0.3, 0.7), back_u = r.uniform();
          const double back_speed = uniform(g.min_velocity_rad_s, g.max_velocity_rad_s);
          if (u_rev < g.reversal_probability) {
            const double turn = at + frac * (target - at);
            move(seg, turn, speed);
            const double bound = target > at ? g.min_deg : g.max_deg;  // the other side of the turn
            target = turn + (bound - turn) * (0.2 + 0.8 * back_u);
            move(seg, target, back_speed);
          } else {
            move(seg, target, speed);
          }
          at = target;
          hold(seg, uniform(g.min_hold_s, g.max_hold_s));
        }
        break;
      }
    }
  }
  st_.angle_deg = s.knee.start_deg;
  st_.commanded_deg = s.knee.start_deg;
  start_step();
}

void Trajectory::gait_command(const Step& g, double t, double& pos, double& vel) const {
  const double phase = t / g.period_s - std::floor(t / g.period_s);
  double d1 = 0, d2 = 0;
  const double b1 = bump(phase, kStanceCentre, kStanceWidth, d1);
  const double b2 = bump(phase, kSwingCentre, kSwingWidth, d2);
  pos = g.min_deg + g.stance_deg * b1 + g.swing_deg * b2;
  vel = (g.stance_deg * d1 + g.swing_deg * d2) / g.period_s;
}

void Trajectory::start_step() {
  tick_in_step_ = 0;
  if (idx_ >= steps_.size()) {
    if (loop_) {
      idx_ = 0;
    } else {
      finished_ = true;
      return;
    }
  }
  st_.segment = steps_[idx_].segment;
}

const KneeState& Trajectory::step() {
  const double v_old = st_.velocity_deg_s;
  if (finished_) {
    st_.velocity_deg_s = 0;
    st_.acceleration_deg_s2 = 0;
    return st_;
  }
  // Zero-length steps (a move to where the knee already is) finish without using a tick; the
  // bound stops a degenerate looping program from spinning.
  for (std::size_t guard = 0; guard <= steps_.size() + 1; ++guard) {
    const Step& s = steps_[idx_];
    if (s.kind == StepKind::kMove) {
      const double d = s.target_deg - st_.angle_deg;
      if (std::abs(d) < 1e-9 && std::abs(st_.velocity_deg_s) < amax_ * dt_) {
        st_.angle_deg = s.target_deg;
        st_.velocity_deg_s = 0;
        ++idx_;
        start_step();
        if (finished_) break;
        continue;
      }
      st_.commanded_deg = s.target_deg;
      // Time-optimal approach: cruise at the commanded speed, brake at the drive's deceleration so
      // as to stop on the target, never change speed faster than amax. The braking speed is the
      // discrete-time one (v^2 / 2a + v dt / 2 = d with x += v dt), so the knee arrives with at most
      // amax dt of residual speed instead of overshooting the continuous v^2 = 2 a d curve.
      const double h = 0.5 * amax_ * dt_;
      const double v_brake = std::sqrt(h * h + 2.0 * amax_ * std::abs(d)) - h;
      const double v_des = std::copysign(std::min(s.speed_deg_s, v_brake), d);
      const double dv = std::clamp(v_des - st_.velocity_deg_s, -amax_ * dt_, amax_ * dt_);
      double v = st_.velocity_deg_s + dv;
      double next = st_.angle_deg + v * dt_;
      if ((s.target_deg - next) * d <= 0 || std::abs(s.target_deg - next) < 1e-9) {
        // Arrives within this tick: stop on the target.
        next = s.target_deg;
        v = 0;
        ++idx_;
        start_step();
      }
      st_.angle_deg = next;
      st_.velocity_deg_s = v;
      break;
    }
    if (s.kind == StepKind::kHold) {
      st_.velocity_deg_s = 0;
      if (++tick_in_step_ >= s.ticks) {
        ++idx_;
        start_step();
      }
      break;
    }
    // kGait: follow the commanded curve with feed-forward velocity plus a position loop, limited.
    const double t = static_cast<double>(tick_in_step_ + 1) * dt_;
    double pc = 0, vc = 0;
    gait_command(s, t, pc, vc);
    st_.commanded_deg = pc;
    const double v_des = std::clamp(vc + kp_ * (pc - st_.angle_deg), -vmax_, vmax_);
    const double dv = std::clamp(v_des - st_.velocity_deg_s, -amax_ * dt_, amax_ * dt_);
    const double v = st_.velocity_deg_s + dv;
    st_.angle_deg += v * dt_;
    st_.velocity_deg_s = v;
    if (++tick_in_step_ >= s.ticks) {
      ++idx_;
      start_step();
    }
    break;
  }
  st_.acceleration_deg_s2 = (st_.velocity_deg_s - v_old) / dt_;
  return st_;
}

}  // namespace pof::sim
