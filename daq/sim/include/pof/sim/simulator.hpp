#pragma once
// The streaming simulator: knee + POF sensor + light path + DAQ front end, one scan at a time.
// Physics and parameters: docs/simulator.md. Deterministic: the same scenario, seed and scan rate
// give the same scans bit for bit (rng.hpp).
//
// Threading: a Simulator is not shared; next() runs on the caller's thread (the DAQ backend's
// acquisition thread or the virtual device's). next() never allocates, never throws and costs a
// few hundred ns per scan (bench_sim), so 48 kS/s aggregate runs in real time with margin.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "pof/sim/rng.hpp"
#include "pof/sim/scenario.hpp"
#include "pof/sim/trajectory.hpp"

namespace pof::sim {

/// One DAQ scan as the device would deliver it (volts after quantisation), plus the reference angle
/// computed with the scenario's nominal potentiometer calibration and the ground truth.
struct Scan {
  double t_s;             // scan time from the start [s] (= index / scan rate)
  double sensor_v, reference_v, pot_v;  // quantised, clipped DAQ readings [V]
  double angle_ref_deg;   // knee.potentiometer.deg_per_volt * (pot_v - zero_v)
  double angle_true_deg;  // the fibre's bend angle (simulator ground truth)
  std::uint8_t over_range;  // bit c set: channel c (Channel enum) clipped at the range in this scan
};

/// What each effect contributed to a scan, for plots and tests (not part of a recording).
struct EffectTrace {
  double velocity_rad_s;       // true, signed (+ flexion)
  double acceleration_rad_s2;  // true
  int direction;               // pof::core::Direction of the sensor model
  double quasi_static_v;       // f5^-1(angle) + static nonlinearity at the true angle [V, normalised]
  double static_nonlinearity_v, hysteresis_v, rate_dependent_hysteresis_v, creep_v,
      acceleration_v, drift_v;  // [V, normalised]
  double memory_hysteresis_v;  // sensor.memory_hysteresis [V, normalised]
  double viscoelastic_lag_v;   // quasi-static line + nonlinearity at the lagged angle minus at the true one
  double lag_deg;              // true angle - the fibre's effective (lagged) angle [deg]
  double memory_state;         // the hysteresis state: Bouc-Wen z, sum w_i e_i / r_i or -sum w_i R_i, in [-1, 1]
  double power_law_relaxation_v;  // sensor.power_law_relaxation [V, normalised]
  double cyclic_softening_v;   // what sensor.cyclic_softening changes: (factor - 1) x the softened terms [V]
  double travel_deg;           // the fibre's accumulated bend travel (with cyclic_softening on, else 0) [deg]
  double normalised_v;         // sum of the above: the noise-free normalised sensor voltage
  double source_power_rel;     // light-source power / nominal
  double pot_error_deg;        // potentiometer angle - true angle (backlash, linearity, vibration)
};

class Simulator {
 public:
  /// scan_rate_hz = 0 takes the scenario's daq.scan_rate_hz. Allocates every buffer here.
  /// Throws pof::ConfigError for an invalid scenario or rate.
  Simulator(const Scenario& s, std::uint64_t seed, double scan_rate_hz);

  /// Fills consecutive scans; returns how many (less than out.size() only at the end; 0 once
  /// finished). No allocation, no exceptions.
  std::size_t next(std::span<Scan> out);
  /// Same, and the effect contributions of each scan (trace.size() >= out.size()).
  std::size_t next(std::span<Scan> out, std::span<EffectTrace> trace);

  [[nodiscard]] double scan_rate_hz() const { return rate_; }
  [[nodiscard]] bool finished() const { return finished_; }
  [[nodiscard]] std::int64_t scans_done() const { return k_; }
  /// LSB [V] and resolution of the simulated converter.
  [[nodiscard]] double lsb_v() const { return lsb_; }
  [[nodiscard]] const Scenario& scenario() const { return sc_; }

 private:
  void step(Scan& out, EffectTrace* tr);
  double bouc_wen_step(double dtheta_deg);
  double preisach_step(double theta_deg);
  double quantise(double v, int channel, std::uint8_t& over) const;

  Scenario sc_;
  double rate_, dt_;
  Trajectory traj_;
  std::int64_t k_ = 0;
  std::int64_t max_scans_ = -1;  // -1: until the trajectory ends
  bool finished_ = false;

  // Converter.
  double lsb_, range_;
  double max_code_;
  std::array<double, kChannels> channel_offset_s_{};  // multiplex time of each channel in a scan

  // State of the memory effects.
  std::vector<double> creep_m_, creep_decay_, creep_gain_;  // Prony terms: state, e^{-dt/tau}, input weight
  double prev_angle_ = 0;      // the fibre's angle of the previous scan (creep input)
  // Viscoelastic lag: the fibre's effective angle, e^{-dt/tau} and the ramp gain tau/dt (1 - e).
  double fibre_angle_ = 0, prev_knee_angle_ = 0, lag_decay_ = 0, lag_gain_ = 0;
  // Memory hysteresis: Bouc-Wen state z, A [1/deg], beta/A, gamma/A and the RK4 sub-step, or the
  // stop operators of Maxwell-slip.
  double bw_z_ = 0, bw_a_ = 0, bw_beta_ = 0, bw_gamma_ = 0, bw_max_substep_deg_ = 1;
  std::vector<double> slip_e_, slip_r_, slip_w_;  // element strain [deg], threshold [deg], weight / threshold
  // Preisach relays: state (+-1), switch-up angle alpha, switch-down angle beta [deg], weight
  // (normalised to sum 1), and the weighted sum of the states at the last update.
  std::vector<double> relay_r_, relay_alpha_, relay_beta_, relay_w_;
  double relay_sum_ = 0;
  // Power-law relaxation: its bank of Prony terms (state, e^{-dt/tau}, input weight, output weight).
  std::vector<double> plr_m_, plr_decay_, plr_gain_, plr_w_;
  double plr_prev_angle_ = 0;
  // Cyclic softening: accumulated |dtheta_f| [deg] and the fibre angle it was last updated at.
  double travel_ = 0, soft_prev_angle_ = 0;
  double mem_prev_angle_ = 0;  // fibre angle at the last hysteresis update
  double speed_filt_ = 0, speed_alpha_ = 1;  // low-passed |omega| [rad/s] and its update gain
  double drift_rw_ = 0, drift_rw_step_ = 0;
  double wander_ = 0, wander_decay_ = 0, wander_kick_ = 0;
  double power_steps_ = 1;
  std::size_t next_power_step_ = 0;
  double backlash_pos_ = 0;
  std::array<double, kChannels> prev_analog_{};
  bool have_prev_ = false;
  // Delay line of one channel (ring buffer of analog values, one per scan).
  std::vector<double> delay_buf_;
  std::size_t delay_head_ = 0;
  double delay_scans_ = 0;
  std::int64_t delay_filled_ = 0;

  // One random stream per source: switching an effect on leaves the others' draws unchanged.
  Rng rng_noise_, rng_drift_, rng_wander_;
};

}  // namespace pof::sim
