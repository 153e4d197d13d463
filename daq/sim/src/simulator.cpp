// One scan of the rig: knee -> belt/potentiometer, knee -> fibre -> photodiodes (with the light
// source shared by sensor and reference), then the multiplexed, quantising DAQ. Physics and the
// meaning of every parameter: docs/simulator.md. The per-scan path (step) only does arithmetic on
// preallocated state: it is called at up to 48 kS/s by the virtual DAQ devices.
#include "pof/sim/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "pof/base/errors.hpp"
#include "pof/core/dynamic_model.hpp"
#include "pof/core/effects.hpp"
#include "pof/core/units.hpp"

namespace pof::sim {

namespace {
using pof::core::kDegPerRad;
constexpr double kTwoPi = 2.0 * std::numbers::pi;
// Random streams (rng.hpp): one per source so that effects switch independently.
constexpr std::uint64_t kStreamNoise = 1, kStreamDrift = 2, kStreamWander = 3;

double checked_rate(const Scenario& s, double override_hz) {
  validate(s);
  const double r = override_hz > 0 ? override_hz : s.daq.scan_rate_hz;
  if (!(r > 0) || !std::isfinite(r) || !(override_hz >= 0))
    throw pof::ConfigError(s.source + ": scan rate: expected a rate > 0 Hz, got " + std::to_string(override_hz));
  return r;
}
}  // namespace

Simulator::Simulator(const Scenario& s, std::uint64_t seed, double scan_rate_hz)
    : sc_(s),
      rate_(checked_rate(s, scan_rate_hz)),
      dt_(1.0 / rate_),
      traj_(s, seed, 1.0 / rate_),
      lsb_(s.daq.lsb_v()),
      range_(s.daq.range_v),
      max_code_(std::ldexp(1.0, s.daq.resolution_bits()) - 1.0),
      rng_noise_(seed, kStreamNoise),
      rng_drift_(seed, kStreamDrift),
      rng_wander_(seed, kStreamWander) {
  if (s.duration_s > 0) max_scans_ = std::llround(s.duration_s * rate_);
  if (s.daq.multiplexed) {
    // The ADC converts the channels of a scan one after the other; if the scan period is too short
    // for the configured convert interval the device would run its convert clock faster.
    const double ci = std::min(s.daq.convert_interval_s, dt_ / kChannels);
    for (std::size_t i = 0; i < kChannels; ++i)
      channel_offset_s_[static_cast<std::size_t>(s.daq.order[i])] = static_cast<double>(i) * ci;
  }
  for (const CreepTerm& c : s.sensor.creep.terms) {
    const double e = std::exp(-dt_ / c.tau_s);
    creep_decay_.push_back(e);
    // Exact update of m' = d(angle)/dt - m/tau for an angle ramping linearly within the tick.
    creep_gain_.push_back(c.tau_s / dt_ * (1.0 - e));
    creep_m_.push_back(0.0);
  }
  // Viscoelastic lag, theta_f' = (theta - theta_f) / tau: exact update of the lag
  // eps = theta - theta_f for a knee angle ramping linearly within the tick (as creep above).
  {
    const double tau = s.sensor.viscoelastic_lag.tau_s;
    lag_decay_ = std::exp(-dt_ / tau);
    lag_gain_ = tau / dt_ * (1.0 - lag_decay_);
  }
  const auto& mh = s.sensor.memory_hysteresis;
  if (mh.enabled && mh.family == MemoryHysteresisFamily::kBoucWen) {
    // Bouc-Wen (Bouc 1967; Wen 1976, J. Eng. Mech. Div. 102(2) 249-263), rate-independent form:
    //   dz = A dtheta - beta |dtheta| |z|^(n-1) z - gamma dtheta |z|^n.
    // With beta + gamma = A the loop saturates at |z| = 1, and per unit A the shape is
    //   dz/dtheta = A f_s(z),  f_s(z) = 1 - |z|^n (b s sgn(z) + 1 - b),  s = sgn(dtheta),
    // b = beta_fraction. A is chosen so that z goes from -1 (saturated in extension) to +0.95
    // in width_deg of flexion: A = L / width_deg with L = integral_{-1}^{0.95} dz / f_+(z).
    const double n = mh.shape, b = mh.beta_fraction;
    auto inv_f = [&](double z) { return 1.0 / (1.0 - std::pow(std::abs(z), n) * ((z < 0 ? -b : b) + 1.0 - b)); };
    auto simpson = [&](double lo, double hi) {
      constexpr int kIntervals = 2000;  // even
      const double h = (hi - lo) / kIntervals;
      double acc = inv_f(lo) + inv_f(hi);
      for (int i = 1; i < kIntervals; ++i) acc += (i % 2 == 1 ? 4.0 : 2.0) * inv_f(lo + i * h);
      return acc * h / 3.0;
    };
    // Split at 0, where sgn(z) (and |z|^n for n < 1) is not smooth.
    const double span = simpson(-1.0, 0.0) + simpson(0.0, 0.95);
    bw_a_ = mh.width_deg > 0 && std::isfinite(span) ? span / mh.width_deg : 0.0;
    bw_beta_ = b;  // beta / A
    bw_gamma_ = 1.0 - b;  // gamma / A
    // RK4 sub-steps small enough that A dtheta <= 0.1 (z moves by at most ~0.2 per sub-step).
    bw_max_substep_deg_ = bw_a_ > 0 ? 0.1 / bw_a_ : 1.0;
  }
  if (mh.enabled && mh.family == MemoryHysteresisFamily::kMaxwellSlip) {
    double wsum = 0;
    for (double w : mh.weights) wsum += w;
    for (std::size_t i = 0; i < mh.thresholds_deg.size(); ++i) {
      slip_e_.push_back(0.0);
      slip_r_.push_back(mh.thresholds_deg[i]);
      slip_w_.push_back(mh.weights[i] / wsum / mh.thresholds_deg[i]);
    }
  }
  if (mh.enabled && mh.family == MemoryHysteresisFamily::kPreisach) {
    // Discretised Preisach model (Mayergoyz 1991): relays on a fixed grid over the centre
    // u = (alpha + beta) / 2 (mean +- 3 spreads) and the half-width v = (alpha - beta) / 2
    // ([max(0, mean - 3 spreads), mean + 3 spreads]), at the cells' midpoints, weighted by the
    // factorised Gaussian density; a spread of 0 is one row. Everything per scan is precomputed here.
    const int nu = mh.centre_spread_deg > 0 ? kPreisachGrid : 1;
    const int nv = mh.half_width_spread_deg > 0 ? kPreisachGrid : 1;
    const double u_lo = mh.centre_deg - 3.0 * mh.centre_spread_deg;
    const double du = 6.0 * mh.centre_spread_deg / nu;
    const double v_lo = std::max(0.0, mh.half_width_deg - 3.0 * mh.half_width_spread_deg);
    const double dv = (mh.half_width_deg + 3.0 * mh.half_width_spread_deg - v_lo) / nv;
    auto z = [](double x, double mean, double spread) { return spread > 0 ? (x - mean) / spread : 0.0; };
    double wsum = 0;
    for (int i = 0; i < nu; ++i) {
      const double u = u_lo + (i + 0.5) * du;
      for (int j = 0; j < nv; ++j) {
        const double v = v_lo + (j + 0.5) * dv;
        const double zu = z(u, mh.centre_deg, mh.centre_spread_deg), zv = z(v, mh.half_width_deg, mh.half_width_spread_deg);
        relay_alpha_.push_back(u + v);
        relay_beta_.push_back(u - v);
        relay_w_.push_back(std::exp(-0.5 * (zu * zu + zv * zv)));
        // The demagnetised state at the start angle: relays centred below it up, the others down
        // (the memory line alpha + beta = 2 theta_0).
        relay_r_.push_back(pof::core::relay_start(s.knee.start_deg, u));
        wsum += relay_w_.back();
      }
    }
    for (std::size_t i = 0; i < relay_w_.size(); ++i) {
      relay_w_[i] /= wsum;
      relay_sum_ += relay_w_[i] * relay_r_[i];
    }
  }
  speed_alpha_ = mh.rate_filter_s > 0 ? 1.0 - std::exp(-dt_ / mh.rate_filter_s) : 1.0;
  if (const auto& pl = s.sensor.power_law_relaxation; pl.enabled) {
    // t^-n = (1 / Gamma(n)) integral of tau^-n e^(-t/tau) d(ln tau): the rectangle rule on a log
    // grid of time constants (3 per decade: ripple < 1e-4 relative) from min_time_s / 10 to
    // max_time_s x 10, plus one term for the spectrum beyond the grid, whose contribution is
    // ~constant over the range: weight tau_e^-n / Gamma(n + 1), time constant tau_e (n + 1) / n
    // (matches it to first order in t / tau_e). docs/simulator.md, "Power-law relaxation".
    constexpr int kPerDecade = 3;
    const double n = pl.exponent, h = std::log(10.0) / kPerDecade;
    const double tau_lo = pl.min_time_s / 10.0;
    const int terms = static_cast<int>(std::ceil(std::log10(100.0 * pl.max_time_s / pl.min_time_s) * kPerDecade)) + 1;
    auto add = [&](double tau, double weight) {
      const double e = std::exp(-dt_ / tau);
      plr_decay_.push_back(e);
      plr_gain_.push_back(tau / dt_ * (1.0 - e));  // as creep: exact for a linear ramp in a tick
      plr_w_.push_back(pl.gain_v_per_deg * weight);
      plr_m_.push_back(0.0);
    };
    for (int j = 0; j < terms; ++j) {
      const double tau = tau_lo * std::exp(j * h);
      add(tau, h * std::pow(tau, -n) / std::tgamma(n));
    }
    const double tau_edge = tau_lo * std::exp((terms - 0.5) * h);
    add(tau_edge * (n + 1.0) / n, std::pow(tau_edge, -n) / std::tgamma(n + 1.0));
  }
  fibre_angle_ = s.knee.start_deg;
  prev_knee_angle_ = s.knee.start_deg;
  mem_prev_angle_ = s.knee.start_deg;
  plr_prev_angle_ = s.knee.start_deg;
  soft_prev_angle_ = s.knee.start_deg;
  drift_rw_step_ = s.sensor.drift.random_walk_v_per_sqrt_hour * std::sqrt(dt_ / 3600.0);
  wander_decay_ = std::exp(-dt_ / s.light.wander.tau_s);
  wander_kick_ = s.light.wander.sigma_rel * std::sqrt(1.0 - wander_decay_ * wander_decay_);
  backlash_pos_ = s.knee.start_deg;
  prev_angle_ = s.knee.start_deg;
  if (s.daq.time_delay.enabled) {
    delay_scans_ = s.daq.time_delay.delay_s * rate_;
    delay_buf_.assign(static_cast<std::size_t>(std::floor(delay_scans_)) + 2, 0.0);
  }
}

std::size_t Simulator::next(std::span<Scan> out) { return next(out, {}); }

std::size_t Simulator::next(std::span<Scan> out, std::span<EffectTrace> trace) {
  const bool with_trace = trace.size() >= out.size();
  std::size_t n = 0;
  for (; n < out.size(); ++n) {
    if (!finished_) {
      if (max_scans_ >= 0) finished_ = k_ >= max_scans_;
      else finished_ = k_ > 0 && traj_.finished();
    }
    if (finished_) break;
    step(out[n], with_trace ? &trace[n] : nullptr);
  }
  return n;
}

double Simulator::quantise(double v, int channel, std::uint8_t& over) const {
  // Offset binary over +-range: code 0 = -range, code 2^bits - 1 = range - LSB; beyond, the
  // converter saturates (clipping) and the block is flagged FLAG_OVER_RANGE.
  double code = std::floor((v + range_) / lsb_ + 0.5);
  if (code < 0 || code > max_code_ || !std::isfinite(code)) {
    code = std::clamp(std::isfinite(code) ? code : max_code_, 0.0, max_code_);
    over = static_cast<std::uint8_t>(over | (1U << channel));
  }
  return code * lsb_ - range_;
}

double Simulator::preisach_step(double theta_deg) {
  // Each relay is up once the angle reaches alpha, down once it falls to beta, else unchanged:
  // exact for any monotone increment between scans. The state is -sum w_i R_i, so that the
  // flexion branch lies above (the voltage falls with bend and lags it), as for the other families.
  double acc = 0;
  for (std::size_t i = 0; i < relay_r_.size(); ++i) {
    const double r = pof::core::relay_step(relay_r_[i], theta_deg, relay_alpha_[i], relay_beta_[i]);
    relay_r_[i] = r;
    acc += relay_w_[i] * r;
  }
  relay_sum_ = acc;
  return std::clamp(-acc, -1.0, 1.0);
}

double Simulator::bouc_wen_step(double dtheta_deg) {
  // Classical RK4 on dz/dtheta = A f_s(z) (constructor), in sub-steps of at most
  // bw_max_substep_deg_; the direction s is constant within one scan's increment.
  if (dtheta_deg == 0.0) return bw_z_;
  const double n = sc_.sensor.memory_hysteresis.shape;
  const bool linear = n == 1.0;
  const double sb = dtheta_deg > 0 ? bw_beta_ : -bw_beta_;
  auto f = [&](double z) {
    const double az = std::abs(z);
    const double p = linear ? az : std::pow(az, n);
    return bw_a_ * (1.0 - p * ((z < 0 ? -sb : sb) + bw_gamma_));
  };
  const double m = std::ceil(std::abs(dtheta_deg) / bw_max_substep_deg_);
  const int subs = m < 1 ? 1 : (m > 1e6 ? 1000000 : static_cast<int>(m));
  const double h = dtheta_deg / subs;
  double z = bw_z_;
  for (int i = 0; i < subs; ++i) {
    const double k1 = f(z);
    const double k2 = f(z + 0.5 * h * k1);
    const double k3 = f(z + 0.5 * h * k2);
    const double k4 = f(z + h * k3);
    z = std::clamp(z + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4), -1.0, 1.0);
  }
  bw_z_ = z;
  return z;
}

void Simulator::step(Scan& out, EffectTrace* tr) {
  if (k_ > 0) traj_.step();
  const KneeState& ks = traj_.state();
  const double t = static_cast<double>(k_) * dt_;
  const double theta = ks.angle_deg;
  const double omega = ks.velocity_deg_s / kDegPerRad;      // rad/s
  const double alpha = ks.acceleration_deg_s2 / kDegPerRad;  // rad/s^2
  const SensorSettings& se = sc_.sensor;

  // --- POF sensor, normalised voltage [V] (what sensor_v would be at nominal source power) ---
  const double w = std::abs(omega);
  using pof::core::Direction;
  const Direction dir = w >= se.hold_threshold_rad_s ? (omega > 0 ? Direction::kFlexion : Direction::kExtension) : Direction::kHold;
  // The fibre's effective bend: the knee angle, or with viscoelastic_lag a first-order lag of it.
  // Every fibre-side term below is evaluated at theta_f (without the lag theta_f == theta exactly,
  // so scenarios without it are unchanged bit for bit); the potentiometer keeps the true angle.
  if (se.viscoelastic_lag.enabled && k_ > 0) {
    const double eps = lag_decay_ * (prev_knee_angle_ - fibre_angle_) + (theta - prev_knee_angle_) * lag_gain_;
    fibre_angle_ = theta - eps;
  } else {
    fibre_angle_ = theta;
  }
  prev_knee_angle_ = theta;
  const double theta_f = fibre_angle_;
  auto nonlinearity = [&se](double th) {
    // Deviation from the straight f5 line over 0-90 deg: a bow (zero at the ends, bow_v at 45 deg)
    // and an S (zero at 0, 45 and 90 deg, +-s_v at 45 -+ 26 deg).
    const double u = pof::core::static_nonlinearity_u(th);
    return se.static_nonlinearity.bow_v * (1.0 - u * u) + se.static_nonlinearity.s_v * 2.598076211353316 * u * (1.0 - u * u);
  };
  const double v_line = pof::core::quasi_static_voltage(se.model, theta_f);
  const double snl = se.static_nonlinearity.enabled ? nonlinearity(theta_f) : 0.0;
  double hyst = 0;
  if (se.hysteresis.enabled && dir != Direction::kHold)
    hyst = se.hysteresis.scale * (pof::core::model_voltage(se.model, theta_f, w, dir) - v_line);  // eqs. (10)-(12)
  double rdh = 0;
  if (se.rate_dependent_hysteresis.enabled && dir != Direction::kHold) {
    const auto& r = se.rate_dependent_hysteresis;
    const double sgn = dir == Direction::kFlexion ? 1.0 : -1.0;
    rdh = sgn * r.amplitude_v * (1.0 - std::exp(-w / r.velocity_scale_rad_s)) * std::sin(std::numbers::pi * std::clamp(theta_f, 0.0, 90.0) / 90.0);
  }
  double creep = 0;
  if (se.creep.enabled) {
    const double dtheta = theta_f - prev_angle_;
    for (std::size_t i = 0; i < creep_m_.size(); ++i) {
      creep_m_[i] = creep_m_[i] * creep_decay_[i] + dtheta * creep_gain_[i];
      creep += se.creep.terms[i].gain_v_per_deg * creep_m_[i];
    }
  }
  prev_angle_ = theta_f;
  double mem = 0, mem_state = 0;
  if (se.memory_hysteresis.enabled) {
    const auto& mh = se.memory_hysteresis;
    const double dtheta = theta_f - mem_prev_angle_;
    mem_prev_angle_ = theta_f;
    if (mh.family == MemoryHysteresisFamily::kBoucWen) {
      mem_state = bouc_wen_step(dtheta);
    } else if (mh.family == MemoryHysteresisFamily::kPreisach) {
      // In a hold no relay can switch: skip the sweep over the grid.
      mem_state = dtheta != 0.0 ? preisach_step(theta_f) : std::clamp(-relay_sum_, -1.0, 1.0);
    } else {
      // Maxwell-slip (Lampaert, Al-Bender, Swevers 2003; Goldfarb and Celanovic 1997): element i
      // is elastic until its slip threshold r_i, e_i <- clamp(e_i + dtheta, -r_i, r_i) (the stop
      // operator); the weighted sum of stop operators is a Prandtl-Ishlinskii operator.
      for (std::size_t i = 0; i < slip_e_.size(); ++i) {
        slip_e_[i] = std::clamp(slip_e_[i] + dtheta, -slip_r_[i], slip_r_[i]);
        mem_state += slip_w_[i] * slip_e_[i];
      }
    }
    // Speed factor exp(k |omega|_f): |omega| low-passed (exact for a step-held input) so the
    // factor changes smoothly at the start and end of a movement.
    speed_filt_ += speed_alpha_ * (w - speed_filt_);
    mem = mh.amplitude_v * mem_state * std::exp(mh.rate_sensitivity_s_per_rad * speed_filt_);
  }
  const double acc = se.acceleration_dependence.enabled ? se.acceleration_dependence.gain_v_per_rad_s2 * alpha : 0.0;
  double drift = 0;
  if (se.drift.enabled) {
    drift = se.drift.rate_v_per_hour * t / 3600.0 + drift_rw_ +
            se.drift.wave_v * std::sin(2 * std::numbers::pi * t / se.drift.wave_period_s);
    if (drift_rw_step_ > 0) drift_rw_ += drift_rw_step_ * rng_drift_.normal();
  }
  double plr = 0;
  if (se.power_law_relaxation.enabled) {
    // A bank of Prony terms updated as creep's (constructor; docs/simulator.md).
    const double dtheta = theta_f - plr_prev_angle_;
    plr_prev_angle_ = theta_f;
    for (std::size_t i = 0; i < plr_m_.size(); ++i) {
      plr_m_[i] = plr_m_[i] * plr_decay_[i] + dtheta * plr_gain_[i];
      plr += plr_w_[i] * plr_m_[i];
    }
  }
  double soft = 0;
  if (se.cyclic_softening.enabled) {
    // The bend response (the line relative to the straight fibre at 0 deg, and the static
    // nonlinearity) and the hysteresis terms scale down with the accumulated travel.
    const auto& cs = se.cyclic_softening;
    travel_ += std::abs(theta_f - soft_prev_angle_);
    soft_prev_angle_ = theta_f;
    const double progress = 1.0 - std::exp(-travel_ / cs.travel_scale_deg);
    const double bend = v_line - pof::core::quasi_static_voltage(se.model, 0.0) + snl;
    soft = -cs.depth * progress * bend - cs.loop_depth * progress * (hyst + rdh + mem);
  }
  // The effects added after the original sum, and only when on, so that scenarios without them
  // give the same doubles bit for bit.
  double v_norm = v_line + snl + hyst + rdh + creep + acc + drift + mem;
  if (se.power_law_relaxation.enabled) v_norm += plr;
  if (se.cyclic_softening.enabled) v_norm += soft;

  // --- light path: one source feeds both fibres, so the reference cancels its power changes ---
  const LightSettings& li = sc_.light;
  double power = 1.0;
  if (li.wander.enabled) {
    power += wander_;
    wander_ = wander_ * wander_decay_ + wander_kick_ * rng_wander_.normal();
  }
  if (li.steps.enabled) {
    while (next_power_step_ < li.steps.steps.size() && t >= li.steps.steps[next_power_step_].at_s)
      power_steps_ *= 1.0 + li.steps.steps[next_power_step_++].relative_change;
    power *= power_steps_;
  }
  double ref_analog = li.reference_level_v * power;
  double sens_analog = v_norm * power;
  if (li.source_power_coupling.enabled) {
    sens_analog = v_norm * std::pow(power, li.source_power_coupling.sensor_exponent);
    ref_analog += li.source_power_coupling.reference_offset_v;
  }

  // --- belt and potentiometer ---
  const KneeSettings& kn = sc_.knee;
  double phi = theta;
  if (kn.backlash.enabled) {
    // Play operator: the pot shaft moves only once the belt's slack of width_deg is taken up.
    backlash_pos_ = pof::core::play_operator(backlash_pos_, theta, 0.5 * kn.backlash.width_deg);
    phi = backlash_pos_;
  }
  double pot_angle = phi;
  if (kn.potentiometer.linearity.enabled) {
    const auto& l = kn.potentiometer.linearity;
    const double u = phi / l.span_deg;
    const double e = l.error_pct / 100.0 * l.span_deg;  // +-2 % of the span (Vishay datasheet class)
    pot_angle += e * (l.shape == LinearityShape::kBow ? std::sin(std::numbers::pi * u) : std::sin(kTwoPi * u));
  }
  if (kn.vibration.enabled && theta > kn.vibration.onset_deg) {
    // Paper section 3.2: near 90 deg the motor vibrates and the potentiometer picks it up.
    const double ramp = std::min(1.0, (theta - kn.vibration.onset_deg) / (90.0 - kn.vibration.onset_deg));
    pot_angle += kn.vibration.amplitude_deg * ramp * std::sin(kTwoPi * kn.vibration.frequency_hz * t);
  }
  const double pot_analog = kn.potentiometer.zero_v + pot_angle / kn.potentiometer.deg_per_volt;

  // --- DAQ: multiplexed sampling, optional delay of one channel, noise, interference, ADC ---
  const DaqSettings& q = sc_.daq;
  std::array<double, kChannels> a{sens_analog, ref_analog, pot_analog};
  std::array<double, kChannels> sampled{};
  for (std::size_t c = 0; c < kChannels; ++c) {
    // Channel c is converted channel_offset_s_[c] after the scan starts: first-order hold on the
    // signal's slope over the last scan period.
    const double slope = have_prev_ ? (a[c] - prev_analog_[c]) / dt_ : 0.0;
    sampled[c] = a[c] + channel_offset_s_[c] * slope;
  }
  prev_analog_ = a;
  have_prev_ = true;
  if (!delay_buf_.empty()) {
    const auto c = static_cast<std::size_t>(q.time_delay.channel);
    const std::size_t n = delay_buf_.size();
    delay_head_ = (delay_head_ + 1) % n;
    delay_buf_[delay_head_] = sampled[c];
    ++delay_filled_;
    // Until the line has filled, the oldest value stands in (the signal before t = 0 is unknown).
    const double lag = std::min(delay_scans_, static_cast<double>(delay_filled_ - 1));
    const auto i0 = static_cast<std::size_t>(std::floor(lag));
    const double f = lag - static_cast<double>(i0);
    const double v0 = delay_buf_[(delay_head_ + n - i0) % n];
    const double v1 = f > 0 ? delay_buf_[(delay_head_ + n - i0 - 1) % n] : v0;
    sampled[c] = (1.0 - f) * v0 + f * v1;
  }
  if (q.noise.enabled) {
    sampled[0] += q.noise.sensor_v * rng_noise_.normal();
    sampled[1] += q.noise.reference_v * rng_noise_.normal();
    sampled[2] += q.noise.pot_v * rng_noise_.normal();
  }
  if (q.periodic_interference.enabled) {
    const auto& m = q.periodic_interference;
    const double ph = m.phase_deg / kDegPerRad;
    for (std::size_t c = 0; c < kChannels; ++c) {
      const double x = kTwoPi * m.frequency_hz * (t + channel_offset_s_[c]) + ph;
      sampled[c] += m.amplitude_v * (std::sin(x) + m.third_harmonic_rel * std::sin(3.0 * x));
    }
  }
  std::uint8_t over = 0;
  out.t_s = t;
  out.sensor_v = quantise(sampled[0], 0, over);
  out.reference_v = quantise(sampled[1], 1, over);
  out.pot_v = quantise(sampled[2], 2, over);
  out.angle_ref_deg = kn.potentiometer.deg_per_volt * (out.pot_v - kn.potentiometer.zero_v);
  out.angle_true_deg = theta;
  out.over_range = over;

  if (tr != nullptr) {
    tr->velocity_rad_s = omega;
    tr->acceleration_rad_s2 = alpha;
    tr->direction = static_cast<int>(dir);
    // The quasi-static terms at the true angle; what the lag shifts them by is viscoelastic_lag_v.
    const double snl_true = se.static_nonlinearity.enabled ? nonlinearity(theta) : 0.0;
    const double qs_true = theta_f == theta ? v_line + snl : pof::core::quasi_static_voltage(se.model, theta) + snl_true;
    tr->quasi_static_v = qs_true;
    tr->static_nonlinearity_v = snl_true;
    tr->hysteresis_v = hyst;
    tr->rate_dependent_hysteresis_v = rdh;
    tr->creep_v = creep;
    tr->acceleration_v = acc;
    tr->drift_v = drift;
    tr->memory_hysteresis_v = mem;
    tr->viscoelastic_lag_v = theta_f == theta ? 0.0 : (v_line + snl) - qs_true;
    tr->lag_deg = theta - theta_f;
    tr->memory_state = mem_state;
    tr->power_law_relaxation_v = plr;
    tr->cyclic_softening_v = soft;
    tr->travel_deg = travel_;
    tr->normalised_v = v_norm;
    tr->source_power_rel = power;
    tr->pot_error_deg = pot_angle - theta;
  }
  ++k_;
}

}  // namespace pof::sim
