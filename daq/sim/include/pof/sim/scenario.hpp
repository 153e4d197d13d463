#pragma once
// A simulation scenario: plain settings, loaded from TOML (daq/sim/scenarios/*.toml, schema_version 1)
// or filled in code (the `pof gap` test harness switches effects on and off here). Every effect has
// its own `enabled` switch and parameters; docs/simulator.md gives the physics and the units.
// Section names of the effects the model-gap workflow (docs/gap.md) hides use its identifiers:
//   sensor.static_nonlinearity, sensor.drift, sensor.creep, sensor.rate_dependent_hysteresis,
//   sensor.acceleration_dependence, daq.time_delay, knee.backlash, light.source_power_coupling,
//   daq.periodic_interference  (see effects.hpp).
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "pof/core/model.hpp"
#include "pof/core/paper_protocol.hpp"

namespace pof::sim {

// ---------------------------------------------------------------- trajectory (commanded motion)
enum class SegmentKind : int {
  kQuasiStatic,  // the paper's quasi-static test: from -> to in steps, a hold at each step
  kCycles,       // flexion/extension cycles at constant velocity (table 1 / table 3 presets)
  kSubject,      // a session with a subject: cycles whose velocity and end angle vary per cycle
  kGait,         // gait-like variable-velocity cycles (two flexion peaks per cycle)
  kHold,         // stay (optionally after moving to angle_deg)
  kRandomMoves,  // point-to-point moves to random targets at random speeds, random holds, reversals
};

struct Segment {
  SegmentKind kind = SegmentKind::kHold;
  std::string label;  // the TOML `kind` as written ("table1", "quasi_static", ...), for plots
  double move_velocity_rad_s = 0.0873;  // speed of positioning moves (5 deg/s)
  // kQuasiStatic
  double from_deg = 0, to_deg = 90, step_deg = 5, hold_s = 10;
  bool descending = false;  // also step back down to from_deg
  // kCycles / kSubject
  std::vector<double> velocities_rad_s;  // one block of cycles per velocity
  int cycles_per_velocity = 1;
  double min_deg = 0, max_deg = 90;
  double pause_s = 1;  // hold at each end of a cycle
  double velocity_jitter_rel = 0;   // kSubject: relative std. dev. of each stroke's velocity
  double amplitude_jitter_deg = 0;  // kSubject: std. dev. of each stroke's end angle
  // kGait
  int cycles = 10;
  double period_s = 6;
  double stance_peak_deg = 15;  // loading-response flexion above min_deg
  // kHold
  double duration_s = 10;
  bool has_angle = false;
  double angle_deg = 0;
  // kRandomMoves (targets in [min_deg, max_deg]; its own random stream per segment)
  int moves = 20;
  double min_velocity_rad_s = 0.05, max_velocity_rad_s = 0.5;  // cruise speed of each move, uniform
  double min_hold_s = 0, max_hold_s = 3;                        // hold after each move, uniform
  double reversal_probability = 0.3;  // a move is abandoned at 30-70 % and reversed at once
};

// ---------------------------------------------------------------- knee, belt, potentiometer
enum class LinearityShape : int { kBow, kS };

struct KneeSettings {
  double start_deg = 0;
  double max_velocity_rad_s = 1.0;       // motor + harmonic drive limits
  double max_acceleration_rad_s2 = 2.0;
  double tracking_gain_per_s = 20;       // gait tracking loop (position error -> velocity)
  struct Backlash { bool enabled = false; double width_deg = 0.5; } backlash;  // toothed belt play
  // Vibration of the motor near 90 deg, transmitted to the potentiometer (paper, section 3.2).
  struct Vibration { bool enabled = false; double amplitude_deg = 0.3, frequency_hz = 12, onset_deg = 75; } vibration;
  struct Potentiometer {
    double zero_v = 0.5;           // pot voltage at 0 deg
    double deg_per_volt = 22.5;    // nominal calibration: angle = deg_per_volt * (pot_v - zero_v)
    struct Linearity { bool enabled = false; double error_pct = 2.0, span_deg = 90; LinearityShape shape = LinearityShape::kBow; } linearity;
  } potentiometer;
};

// ---------------------------------------------------------------- POF sensor
struct CreepTerm {
  double tau_s = 5;              // relaxation time of this Prony term
  double gain_v_per_deg = -0.002;  // voltage per degree of sudden bend that relaxes with tau_s
};

enum class MemoryHysteresisFamily : int {
  kBoucWen,      // smooth Bouc-Wen loop (Bouc 1967, Wen 1976)
  kMaxwellSlip,  // Maxwell-slip / Prandtl-Ishlinskii: weighted stop operators
  kPreisach,     // discretised Preisach model: relays with a Gaussian density (Mayergoyz 1991)
};

// sensor.memory_hysteresis.family = "preisach" runs a fixed grid of this many relays per axis of
// the (centre, half-width) half-plane (docs/simulator.md, "Continuous hysteresis with memory").
inline constexpr int kPreisachGrid = 20;

struct SensorSettings {
  pof::core::ModelCoefficients model = pof::core::paper_coefficients();
  double hold_threshold_rad_s = 0.01;  // |w| below this is a hold (the gap workflow's baseline rule, docs/gap.md)
  struct Hysteresis { bool enabled = true; double scale = 1.0; } hysteresis;  // the paper's f1-f4
  struct StaticNonlinearity { bool enabled = false; double bow_v = 0.02, s_v = 0; } static_nonlinearity;
  struct RateDependentHysteresis { bool enabled = false; double amplitude_v = 0.02, velocity_scale_rad_s = 0.1; } rate_dependent_hysteresis;
  struct Creep { bool enabled = false; std::vector<CreepTerm> terms{CreepTerm{}}; } creep;
  struct AccelerationDependence { bool enabled = false; double gain_v_per_rad_s2 = 0.02; } acceleration_dependence;
  // A trend, a random walk and a slow oscillation (a room's temperature regulation cycling).
  struct Drift {
    bool enabled = false;
    double rate_v_per_hour = 0.02, random_walk_v_per_sqrt_hour = 0;
    double wave_v = 0, wave_period_s = 900;
  } drift;
  // Continuous hysteresis with memory (rate independent in itself, times an optional speed factor
  // exp(rate_sensitivity_s_per_rad * |omega|_lowpassed)); its state persists through holds.
  struct MemoryHysteresis {
    bool enabled = false;
    MemoryHysteresisFamily family = MemoryHysteresisFamily::kBoucWen;
    double amplitude_v = 0.025;  // half-height at saturation; > 0: the flexion branch lies above
    double rate_sensitivity_s_per_rad = 0;  // < 0: the loop narrows with speed, > 0: widens
    double rate_filter_s = 0.2;  // low-pass of |omega| for the speed factor (0: none)
    // bouc_wen
    double width_deg = 10;       // angle to go from one saturation to 95 % of the other
    double shape = 1;            // Bouc-Wen exponent n
    double beta_fraction = 0.5;  // beta / (beta + gamma)
    // maxwell_slip
    std::vector<double> thresholds_deg{2, 5, 10};  // slip threshold of each element
    std::vector<double> weights{1, 1, 1};          // relative, normalised to sum 1
    // preisach: relays switching up at alpha and down at beta <= alpha, with a factorised Gaussian
    // density over the centre u = (alpha + beta) / 2 and the half-width v = (alpha - beta) / 2.
    double centre_deg = 45;            // mean relay centre
    double centre_spread_deg = 12;     // std. dev. of the centres (the interaction spread)
    double half_width_deg = 15;        // mean relay half-width (the coercive angle)
    double half_width_spread_deg = 6;  // std. dev. of the half-widths (truncated at 0)
  } memory_hysteresis;
  // First-order lag of the fibre's effective bend behind the knee (Kelvin-Voigt-like):
  // theta_f' = (theta - theta_f) / tau. The fibre-side terms are evaluated at theta_f.
  struct ViscoelasticLag { bool enabled = false; double tau_s = 0.3; } viscoelastic_lag;
  // Nutting (fractional) relaxation: a sudden bend of d deg adds gain_v_per_deg * d * (t / 1 s)^-n,
  // t the time since the bend, over [min_time_s, max_time_s]; run as a fixed bank of Prony terms.
  struct PowerLawRelaxation {
    bool enabled = false;
    double gain_v_per_deg = -0.0003;  // the response 1 s after the bend, per degree of bend
    double exponent = 0.3;            // n, in (0, 1)
    double min_time_s = 0.1, max_time_s = 300;  // where the t^-n law holds
  } power_law_relaxation;
  // Cyclic softening of the PMMA: with L the fibre's accumulated bend travel (sum of |dtheta_f|),
  // the bend sensitivity is multiplied by 1 - depth (1 - exp(-L / travel_scale_deg)), the
  // hysteresis terms by the same with loop_depth.
  struct CyclicSoftening {
    bool enabled = false;
    double depth = 0.05;       // fraction of the sensitivity lost after a long run, [0, 1)
    double loop_depth = 0;     // fraction of the hysteresis loop lost, [0, 1)
    double travel_scale_deg = 5000;  // L0 [deg]
  } cyclic_softening;
};

// ---------------------------------------------------------------- light path
struct PowerStep {
  double at_s = 0;
  double relative_change = 0;  // source power is multiplied by (1 + relative_change) from at_s on
};

struct LightSettings {
  double reference_level_v = 4.0;  // reference photodiode voltage at nominal source power
  struct Wander { bool enabled = false; double sigma_rel = 0.01, tau_s = 60; } wander;
  struct Steps { bool enabled = false; std::vector<PowerStep> steps; } steps;
  // Imperfect cancellation: sensor photodiode ~ P^sensor_exponent, reference with a dark offset.
  struct SourcePowerCoupling { bool enabled = false; double sensor_exponent = 1.3, reference_offset_v = 0; } source_power_coupling;
};

// ---------------------------------------------------------------- DAQ front end
enum class Device : int { kUsb6008, kUsb6009 };
enum class Terminal : int { kRse, kDifferential };
enum class Channel : int { kSensor = 0, kReference = 1, kPot = 2 };
inline constexpr int kChannels = 3;

struct DaqSettings {
  Device device = Device::kUsb6008;
  Terminal terminal = Terminal::kDifferential;
  double range_v = 5;      // +-range_v; RSE is +-10 V only
  int bits = 0;            // 0: the device's resolution for the terminal mode
  double scan_rate_hz = 200;
  std::array<Channel, kChannels> order{Channel::kSensor, Channel::kReference, Channel::kPot};
  double convert_interval_s = 1e-4;  // multiplexed ADC: channel i of a scan is taken i * this later
  bool multiplexed = true;
  struct Noise { bool enabled = false; double sensor_v = 0.001, reference_v = 0.001, pot_v = 0.001; } noise;
  struct PeriodicInterference { bool enabled = false; double frequency_hz = 50, amplitude_v = 0.003, phase_deg = 0, third_harmonic_rel = 0; } periodic_interference;
  struct TimeDelay { bool enabled = false; Channel channel = Channel::kSensor; double delay_s = 0.05; } time_delay;

  /// Effective resolution [bits]: `bits` if set, else USB-6008 11 (RSE) / 12 (differential),
  /// USB-6009 13 (RSE) / 14 (differential) (NI USB-6008/6009 user guide, AI specifications).
  [[nodiscard]] int resolution_bits() const;
  /// One code step [V] = 2 range / 2^bits.
  [[nodiscard]] double lsb_v() const;
};

// ---------------------------------------------------------------- the whole scenario
struct Scenario {
  int schema_version = 1;
  std::string name;         // `name` key, else the file stem
  std::string description;
  std::string source;       // file (or "builtin:<name>") it was loaded from, for messages
  std::string sensor_id;    // raw_block_t.sensor_id of recordings
  double duration_s = 0;    // 0: until the trajectory ends (loop: forever)
  bool loop = false;        // restart the trajectory when it ends (for streaming devices)
  KneeSettings knee;
  SensorSettings sensor;
  LightSettings light;
  DaqSettings daq;
  std::vector<Segment> trajectory;
};

/// Throws pof::ConfigError naming the file, line and key (e.g. "x.toml:12: key
/// 'sensor.creep.terms[0].tau_s': expected a number > 0, got -1"), also for unknown keys.
/// Throws pof::NoInputError when the file cannot be read.
Scenario load_scenario(const std::filesystem::path& path);
/// Same, from TOML text; `source` names it in messages.
Scenario parse_scenario(std::string_view toml_text, const std::string& source);
/// The shipped scenarios ("paper", "realistic"), embedded in the library at build time.
/// Throws pof::NoInputError for an unknown name.
Scenario builtin_scenario(std::string_view name);
std::vector<std::string> builtin_scenario_names();
/// A scenario file when `name_or_path` looks like a path (has a '/' or ends in ".toml"), else the
/// built-in scenario of that name (how daq.toml's `device.kind = "sim:<x>"` and the virtual
/// devices' --sim-scenario name one). Throws as load_scenario() / builtin_scenario().
Scenario scenario_by_name_or_path(const std::string& name_or_path);
/// Re-checks a scenario built in code; throws ConfigError naming the field.
void validate(const Scenario& s);

/// The paper's table-1 and table-3 velocities (defined in pof/core/paper_protocol.hpp).
using core::kTable1Velocities;
using core::kTable3Velocities;

std::string_view to_string(Channel c);

}  // namespace pof::sim
