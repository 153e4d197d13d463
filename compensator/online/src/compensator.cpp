#include "pof/core/compensator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "pof/core/effects.hpp"

namespace pof::core {

namespace {
constexpr double kRadPerDeg = std::numbers::pi / 180.0;
// Running sums drift by rounding; rebuilding them from the window this often keeps the error at
// the 1e-12 level at a cost of N/4096 operations per scan.
constexpr std::int64_t kRefreshScans = 4096;
}  // namespace

OnlineCompensator::OnlineCompensator(const Calibration& cal, const CompensatorSettings& s) : cal_(cal), s_(s) {
  if (!(s.scan_rate_hz > 0) || !(s.velocity_window_s > 0))
    throw std::invalid_argument("compensator: scan_rate_hz and velocity_window_s must be > 0");
  if (!(s.hold_rad_s >= 0) || !(s.hold_rad_s < s.move_rad_s))
    throw std::invalid_argument("compensator: need 0 <= hold_rad_s < move_rad_s (the dead band)");
  if (!(cal.reference_level_v > 0)) throw std::invalid_argument("compensator: reference level must be > 0");
  n_ = static_cast<int>(std::lround(s.velocity_window_s * s.scan_rate_hz));
  if (n_ < 2) n_ = 2;
  if (n_ > 1'000'000) throw std::invalid_argument("compensator: velocity window too long");
  ring_.assign(static_cast<std::size_t>(n_), 0.0);
  if (s.reversal_window_s > 0) {
    if (!(s.reversal_rad_s > s.move_rad_s))
      throw std::invalid_argument("compensator: reversal_rad_s must exceed move_rad_s");
    if (!(s.reversal_window_s <= s.velocity_window_s))
      throw std::invalid_argument("compensator: reversal_window_s must not exceed velocity_window_s");
    m_ = std::clamp(static_cast<int>(std::lround(s.reversal_window_s * s.scan_rate_hz)), 2, n_);
  }
  if (s.model_steps && cal.active != ModelKind::kDynamic && s.velocity_source == VelocitySource::kSensor) {
    if (!(s.step_block_s > 0 && std::isfinite(s.step_block_s)) || !(s.step_tolerance > 0 && s.step_tolerance < 1) ||
        !(s.step_min_snr > 0 && std::isfinite(s.step_min_snr)) || !(s.step_min_deg >= 0 && std::isfinite(s.step_min_deg)) ||
        !(s.reversal_rad_s > s.move_rad_s))
      throw std::invalid_argument(
          "compensator: model steps need a finite step_block_s > 0, 0 < step_tolerance < 1, finite step_min_snr > 0 "
          "and step_min_deg >= 0, and reversal_rad_s > move_rad_s");
    // A block of at least 3 scans (of 2, one noisy scan past the line would be a step), and the
    // block and the 3 before it must fit the window; otherwise model steps are off (a velocity
    // window under 0.06 s at 200 Hz).
    const double block = std::max(3.0, std::round(s.step_block_s * s.scan_rate_hz));
    if (4 * block <= n_) {
      step_m_ = static_cast<int>(block);
      step_scratch_.assign(static_cast<std::size_t>(4 * step_m_), 0.0);
    }
  }
  if (cal.active == ModelKind::kDynamic) {
    if (!cal.dynamic) throw std::invalid_argument("compensator: the dynamic model is selected but the calibration has none");
    if (const char* why = cal.dynamic->invalid_reason(); *why != '\0')
      throw std::invalid_argument(std::string("compensator: dynamic model: ") + why);
    dynamic_ = true;
    inverter_ = DynamicInverter(*cal.dynamic, s.scan_rate_hz);
  }
  if (cal.gap && !cal.gap->empty()) {
    if (const auto problems = gap_problems(*cal.gap, s.scan_rate_hz); !problems.empty())
      throw std::invalid_argument("compensator: " + problems.front().describe());
    quiet_chain_.terms = GapCorrector(cal, s.scan_rate_hz);
    // The acceleration is estimated once, on the quiet angle, for both chains (see quiet_chain_).
    GapModel published = *cal.gap;
    std::erase_if(published.terms, [](const GapTerm& t) { return effect_of(t.effect) == Effect::kAccelerationDependence; });
    Calibration without_acceleration = cal;
    without_acceleration.gap = std::move(published);
    terms_chain_.terms = GapCorrector(without_acceleration, s.scan_rate_hz);
    terms_ = true;
    if (dynamic_ && cal.gap->backlash_deg > 0) {
      play_inverter_ = DynamicInverter(*cal.dynamic, s.scan_rate_hz);
      play_inverse_ = true;
    }
  }
  guard_.level_v = cal.reference_level_v;
  guard_.min_ratio = s.reference_min_ratio;
  guard_.max_ratio = s.reference_max_ratio;
  guard_.min_abs_v = s.reference_min_v;
}

void OnlineCompensator::clear_window() noexcept {
  head_ = count_ = 0;
  s0_ = s1_ = 0;
  since_refresh_ = 0;
  phase_ = Direction::kHold;
  step_offset_ = 0;
  step_hold_ = 0;
}

void OnlineCompensator::reset() noexcept {
  clear_window();
  inverter_.reset();  // the memory of the lost scans is unknown: start from a relaxed state
  play_inverter_.reset();
  terms_chain_.restart();
  quiet_chain_.restart();
  gap_pending_ = true;
}

double OnlineCompensator::terms_voltage(double v, double reference_v, double w, Direction d) const noexcept {
  if (!terms_) return 0.0;
  const double guess = std::isfinite(terms_chain_.angle) ? terms_chain_.angle : quasi_static_angle(cal_.model, v);
  return terms_voltage(terms_chain_, v, reference_v, w, d, model_slope(guess, w, d));
}

double OnlineCompensator::quiet_angle(double v, double reference_v, double* g) const noexcept {
  // f5 is the hold's model (dA/dv = -c9 everywhere) and this angle decides the direction: the
  // terms that switch with it (rate_dependent_hysteresis) are off here, as in a hold.
  *g = terms_voltage(quiet_chain_, v, reference_v, 0.0, Direction::kHold, -cal_.model.c9);
  return quasi_static_angle(cal_.model, v - *g);
}

void OnlineCompensator::commit_quiet(double angle, double u, double reference_v) noexcept {
  quiet_chain_.angle = angle;
  quiet_chain_.u = u;
  quiet_committed_ = true;
  const double play_angle = play_inverse_ ? play_inverter_.step(u).angle_deg : std::nan("");
  // On the paper chain a positive delay is not extrapolated while the direction is a hold: there
  // the quiet angle's slope is mostly that of the step f5 of the voltage makes as the sensor
  // leaves its branch at a stop (eqs. (11)/(12)), which the fit window would carry into the hold.
  // The price: a start is named up to a velocity window late, and is not extrapolated until then
  // (docs/calibration.md, "[gap]", step 6).
  const bool extrapolate = dynamic_ || phase_ != Direction::kHold;
  // f5's slope reconstructs the angle without the acceleration term for its own window.
  quiet_chain_.terms.advance(angle, reference_v, quiet_chain_.terms.has_acceleration() ? -cal_.model.c9 : 0.0, play_angle,
                             extrapolate);
}

void OnlineCompensator::skip_quiet() noexcept {
  // The play's inverse has no angle this scan: its bend-lag window must not span the gap.
  if (play_inverse_) play_inverter_.step(std::nan(""));
}

double OnlineCompensator::terms_voltage(const TermsChain& c, double v, double reference_v, double w, Direction d,
                                        double slope) const noexcept {
  const double guess = std::isfinite(c.angle) ? c.angle : quasi_static_angle(cal_.model, v);
  const double g0 = c.terms.voltage_at(guess, reference_v, w, d);
  if (!std::isfinite(c.angle) || !std::isfinite(c.u)) return g0;
  // This scan's A solves A = model^-1(v - g(A)) (docs/calibration.md, "[gap]", step 2), the
  // model linearised at the previous angle A0 (slope s = dA/dv), the terms exact:
  //   F(A) = A - A0 - s (v - g(A) - u_prev) = 0,   F' = 1 + s g'.
  // Evaluated at A0 alone, g closes a loop whose error e_k = -s g' e_k-1 oscillates and grows once
  // |s g'| > 1: a strong memory hysteresis near a reversal read 9 deg RMSE on a blind recording.
  // One Newton step is not enough either: stop and play operators make g piecewise linear with a
  // kink near A0, at the operators' committed (low-passed) angle: elastic on one side, sliding on
  // the other, and a slope from the wrong side overshoots; a term that flattened the line to a
  // third swung the angle by +-5 deg from scan to scan through a hold. So the search steps by
  // Newton with the slope of the side it moves to until F changes sign, then closes the bracket
  // by regula falsi (Illinois). The combined voltage must stay monotone in A (F' > 0, as the
  // dynamic model's inverse requires of its own terms); where the terms would nearly cancel the
  // model's slope the step's divisor is held at kMinTermsDivisor, and without a sign change the
  // search keeps its last angle.
  double gval = g0;
  auto F = [&](double a) {
    gval = c.terms.voltage_at(a, reference_v, w, d);
    return a - guess - slope * (v - gval - c.u);
  };
  double a = guess, fa = F(a), ga = gval;
  if (!std::isfinite(fa)) return g0;
  double b = a, fb = fa, gb = ga;
  // Without a bracket (the terms turning the voltage back where F' < 0) the steps can lead away:
  // the angle with the smallest |F| seen is the one kept.
  double best_f = std::abs(fa), best_g = ga;
  bool bracketed = false;
  for (int it = 0; it < kTermsSearchSteps && fb != 0; ++it) {
    const double dir = fb > 0 ? -1.0 : 1.0;
    const double g1 = c.terms.voltage_at(b + dir * kTermsSlopeStepDeg, reference_v, w, d);
    const double dfdA = 1.0 + slope * (g1 - gb) / (dir * kTermsSlopeStepDeg);
    const double next = b - fb / std::max(std::isfinite(dfdA) ? dfdA : 1.0, kMinTermsDivisor);
    const double fn = F(next);
    if (!std::isfinite(fn)) return best_g;
    if (std::abs(fn) < best_f) { best_f = std::abs(fn); best_g = gval; }
    if ((fn > 0) != (fb > 0)) { a = b; fa = fb; ga = gb; b = next; fb = fn; gb = gval; bracketed = true; break; }
    b = next; fb = fn; gb = gval;
  }
  if (!bracketed) return best_g;
  // Illinois halves the kept end's F to move the secant; each end's own |F| is kept beside it.
  double ra = std::abs(fa), rb = std::abs(fb);
  int side = 0;
  for (int it = 0; it < kTermsSearchSteps && std::abs(b - a) > kTermsTolDeg; ++it) {
    const double m = (a * fb - b * fa) / (fb - fa);
    const double fm = F(m);
    if (!std::isfinite(fm)) break;
    if (fm == 0) return gval;
    if ((fm > 0) == (fb > 0)) { b = m; fb = fm; rb = std::abs(fm); gb = gval; if (side == -1) fa /= 2; side = -1; }
    else { a = m; fa = fm; ra = std::abs(fm); ga = gval; if (side == 1) fb /= 2; side = 1; }
  }
  return ra < rb ? ga : gb;
}

double OnlineCompensator::model_slope(double angle, double w, Direction d) const noexcept {
  // f3..f5 are affine in v (f5 alone in holds); the dynamic model's quasi-static slope (its loop's
  // is small).
  if (dynamic_) return 1.0 / cal_.dynamic->quasi_static_slope(angle);
  if (d == Direction::kHold) return -cal_.model.c9;
  const DirectionCoefficients& x = cal_.model.of(d);
  return -cal_.model.c9 * x.c7 * f3_line(cal_.model, x, std::abs(w)).a;
}

double OnlineCompensator::angle_of(double v, double reference_v, double w, Direction d, bool* clamped) noexcept {
  double angle = 0;
  if (dynamic_) {
    const DynamicInverter::Result r = inverter_.step(v);
    angle = r.angle_deg;
    *clamped = r.clamped;
  } else {
    angle = compensated_angle(cal_.model, v, std::abs(w), d);  // f5 alone in holds
  }
  if (!terms_) return angle;
  if (!std::isfinite(angle)) {
    terms_chain_.terms.interrupt();
    return angle;
  }
  terms_chain_.angle = angle;
  terms_chain_.u = v;
  const double own = terms_chain_.terms.advance(angle, reference_v, 0.0);  // delay and backlash undone
  if (!quiet_committed_) return own;
  // The velocity extrapolation's slope and the play's side come from the quiet chain, which ran
  // the same kinematics on the quiet angle this scan (see quiet_chain_ and commit_quiet); a
  // negative delay (the angle |d| ago) is exact on this angle and stays its own.
  const GapCorrector::Kinematics& q = quiet_chain_.terms.last_kinematics();
  const double joint = terms_chain_.terms.extrapolates() ? angle + (q.joint - q.angle) : terms_chain_.terms.last_kinematics().joint;
  return joint + (q.reference - q.joint);
}

double OnlineCompensator::delay_s() const noexcept { return (n_ - 1) / (2.0 * s_.scan_rate_hz); }

double OnlineCompensator::velocity_noise_rad_s(double angle_noise_deg) const noexcept {
  const double n = n_;
  return angle_noise_deg * std::sqrt(12.0 / (n * (n * n - 1))) * s_.scan_rate_hz * kRadPerDeg;
}

double OnlineCompensator::push(double y) noexcept {
  auto at = [this](int i) -> double& { return ring_[static_cast<std::size_t>(i)]; };
  if (count_ < n_) {
    s1_ += count_ * y;
    s0_ += y;
    at((head_ + count_) % n_) = y;
    ++count_;
  } else {
    const double old = at(head_);
    s1_ += -(s0_ - old) + (n_ - 1) * y;
    s0_ += y - old;
    at(head_) = y;
    head_ = (head_ + 1) % n_;
    if (++since_refresh_ >= kRefreshScans) refresh_sums();
  }
  return push_slope();
}

double OnlineCompensator::push_slope() const noexcept {
  const double m = count_;
  if (count_ < 2) return std::nan("");
  const double sj = m * (m - 1) / 2, sjj = (m - 1) * m * (2 * m - 1) / 6;
  return (m * s1_ - sj * s0_) / (m * sjj - sj * sj);
}

void OnlineCompensator::refresh_sums() noexcept {
  since_refresh_ = 0;
  s0_ = s1_ = 0;
  for (int j = 0; j < count_; ++j) {
    const double v = ring_[static_cast<std::size_t>((head_ + j) % n_)];
    s0_ += v;
    s1_ += j * v;
  }
}

double& OnlineCompensator::ring_back(int back) noexcept {
  // head_ + count_ - 1 - back lies in (-n_, 2 n_): one wrap instead of a division.
  int i = head_ + count_ - 1 - back;
  if (i >= n_) i -= n_;
  else if (i < 0) i += n_;
  return ring_[static_cast<std::size_t>(i)];
}

double OnlineCompensator::predicted_step(double angle, Direction from, Direction to) const noexcept {
  // B_d(A) = f5(V_d(A, w_min)) - A: where the f5 angle sits on branch d (0 in a hold). The sensor
  // changes branch as its speed passes through the lowest speeds, so the branches are taken there.
  auto offset = [&](Direction d) {
    if (d == Direction::kHold) return 0.0;
    return quasi_static_angle(cal_.model, model_voltage(cal_.model, angle, cal_.velocity_min_rad_s, d)) - angle;
  };
  return offset(to) - offset(from);
}

Direction OnlineCompensator::model_step() noexcept {
  if (step_m_ == 0 || count_ < n_) return phase_;
  // The newest scans against the straight line through the 3M angles before the newest block of
  // M: a movement that goes on as before cancels, and so does one whose speed changes no faster
  // than a knee's within those 0.1 s (docs/calibration.md, "Model steps").
  const int m = step_m_, k = 3 * m;
  // The newest 4M angles, newest first, copied out of the ring once (x[back]).
  double* const x = step_scratch_.data();
  for (int back = 0, i = (head_ + count_ - 1) % n_; back < m + k; ++back, i = i == 0 ? n_ - 1 : i - 1)
    x[back] = ring_[static_cast<std::size_t>(i)];
  double mean = 0, sxy = 0;
  for (int i = 0; i < k; ++i) mean += x[m + i];
  mean /= k;
  const double centre = m + (k - 1) / 2.0;  // the line's centre, in scans back from the newest
  for (int i = 0; i < k; ++i) sxy += (m + i - centre) * (x[m + i] - mean);
  const double sxx = k * (static_cast<double>(k) * k - 1) / 12.0;
  auto past_line = [&](int back) { return x[back] - (mean + sxy / sxx * (back - centre)); };
  // The measured step: the newest M - 1 scans past the line (a step is taken once it is M - 1
  // scans old; the oldest scan of the block may still be from before it).
  double measured = 0;
  for (int i = 0; i < m - 1; ++i) measured += past_line(i);
  measured /= m - 1;
  // Its spread without steps, measured on the statistic itself: white noise, a 12-bit converter's
  // staircase under a slow movement (the line through one flat stair misses the next by up to a
  // code plus the movement), vibration. A running mean of its square over the first two windows,
  // then an exponential one over four, each square held below 16 times the estimate so that the
  // steps themselves barely count; the cap never goes below 16 (step_min_deg / step_min_snr)^2,
  // under which the minimum step (step_min_deg) decides anyway, so that an estimate that learnt
  // zero (a converter that read the same code through a still start) still grows once the knee
  // moves.
  // It is a property of the sensor and converter: reset() keeps it.
  const double q = measured * measured;
  if (std::isfinite(q)) {
    const double floor = s_.step_min_deg / s_.step_min_snr;
    ++stat_count_;
    const double held = stat_count_ > 2 * n_ ? std::min(q, 16 * std::max(stat_var_, floor * floor)) : q;
    stat_var_ += (held - stat_var_) / static_cast<double>(std::min<std::int64_t>(stat_count_, 4 * static_cast<std::int64_t>(n_)));
  }
  if (stat_count_ < 2 * n_ || step_hold_ > n_ - m) return phase_;  // one step per block
  const double noise = std::sqrt(stat_var_);
  // No prediction can fit a measured step below (1 - tolerance) of the smallest one looked for:
  // most scans end here, before the model's branches are evaluated.
  if (std::abs(measured) < (1 - s_.step_tolerance) * std::max(s_.step_min_snr * noise, s_.step_min_deg)) return phase_;
  const double angle = mean - sxy / sxx * centre + step_offset_;  // the f5 angle now, without the step
  // A stop (to hold) is taken when it fits; otherwise the nearest prediction, if it fits. Where a
  // stop and a reversal both fit, their steps, and so the angles they give, differ little, and a
  // knee that does turn shows it in the window soon after (step() lets the window name the new
  // direction then). To fit, the prediction must be within the tolerance, large enough to tell
  // from the statistic's spread, and a step, not a few noisy scans: each of the M - 1 newest
  // scans more than half of it past the line. Otherwise the next scan tries again.
  auto fits = [&](double p) {
    return std::isfinite(p) && std::abs(p) >= std::max(s_.step_min_snr * noise, s_.step_min_deg) &&
           std::abs(measured - p) <= s_.step_tolerance * std::abs(p);
  };
  Direction best = phase_;
  double predicted = phase_ != Direction::kHold ? predicted_step(angle, phase_, Direction::kHold) : 0.0;
  if (phase_ != Direction::kHold && fits(predicted)) {
    best = Direction::kHold;
  } else {
    double best_miss = std::numeric_limits<double>::infinity();
    for (const Direction to : {Direction::kHold, Direction::kFlexion, Direction::kExtension}) {
      const double p = predicted_step(angle, phase_, to);
      if (to == phase_ || !std::isfinite(p) || std::abs(measured - p) >= best_miss) continue;
      best_miss = std::abs(measured - p);
      best = to;
      predicted = p;
    }
    if (best == phase_ || !fits(predicted)) return phase_;
  }
  int run = 0;
  while (run < m && past_line(run) * predicted > 0.5 * predicted * predicted) ++run;
  if (run < m - 1) return phase_;
  // The step's scans are moved back by it, and every later angle by the same offset.
  for (int i = 0; i < run; ++i) ring_back(i) -= measured;
  step_offset_ += measured;
  refresh_sums();
  step_hold_ = n_;
  return best;
}

double OnlineCompensator::recent_slope(int k) const noexcept {
  // Direct least squares over the newest k scans of the ring: O(k).
  if (k < 2 || count_ < k) return std::nan("");
  const int newest = (head_ + count_ - 1) % n_;
  const double jbar = (k - 1) / 2.0;
  double sxy = 0;
  for (int j = 0; j < k; ++j) {
    const int i = (newest - (k - 1) + j + n_) % n_;
    sxy += (j - jbar) * ring_[static_cast<std::size_t>(i)];
  }
  return sxy / (k * (static_cast<double>(k) * k - 1) / 12.0);
}

double OnlineCompensator::short_slope() const noexcept {
  return m_ == 0 ? std::nan("") : recent_slope(m_);  // m_ = 20 at 0.1 s x 200 Hz
}

CompensatedScan OnlineCompensator::step(double sensor_v, double reference_v, double angle_ref_deg) noexcept {
  CompensatedScan out;
  quiet_committed_ = false;
  if (gap_pending_) {
    out.quality |= quality::kGap;
    gap_pending_ = false;
  }
  if (std::abs(sensor_v) >= s_.input_limit_v || std::abs(reference_v) >= s_.input_limit_v)
    out.quality |= quality::kOverRange;
  const Normalised nz = normalise(sensor_v, reference_v, guard_);
  const double nan = std::nan("");
  if (!nz.ok) {
    // Unusable scan: the window is emptied so that the velocity is never computed across it.
    out.quality |= nz.finite_input ? quality::kReferenceLost : quality::kInvalidInput;
    out.quality |= quality::kSettling;
    out.angle_deg = out.angle_uncomp_deg = out.velocity_rad_s = nan;
    clear_window();
    // The dynamic inverse keeps the fibre's memory across the scan (the operators and Prony terms
    // are the fibre's state, not a window), but its bend-lag inverse differentiates a window that
    // must not span the scans it never saw: after a 0.2 s loss mid-swing it read the 20 deg the
    // knee moved meanwhile as speed, 54 deg off with an 80 ms lag (test_dynamic_model.cpp).
    if (dynamic_) inverter_.step(nan);
    if (terms_) {
      terms_chain_.terms.interrupt();
      quiet_chain_.terms.interrupt();
      skip_quiet();
    }
    return out;
  }
  out.angle_uncomp_deg = quasi_static_angle(cal_.model, nz.v);
  // [gap] periodic interference is notched out before either model sees the voltage.
  const double v = terms_ ? terms_chain_.terms.filter(nz.v) : nz.v;
  bool clamped = false;
  // With [gap] terms the velocity is estimated on f5 of the voltage after the quiet chain's terms
  // (see quiet_chain_): never on an angle that went through the direction it is to decide.
  double g_quiet = 0;
  const double y_quiet = terms_ ? quiet_angle(v, reference_v, &g_quiet) : out.angle_uncomp_deg;
  if (terms_ && !std::isfinite(y_quiet)) quiet_chain_.terms.interrupt();
  const double y = s_.velocity_source == VelocitySource::kReference ? angle_ref_deg : y_quiet;
  if (!std::isfinite(y)) {
    out.quality |= quality::kInvalidInput | quality::kSettling;
    // The dynamic model needs no velocity; the paper's falls back to f5 without one.
    const double g = terms_voltage(v, reference_v, nan, Direction::kHold);
    out.angle_deg = angle_of(v - g, reference_v, nan, Direction::kHold, &clamped);
    out.velocity_rad_s = nan;
    clear_window();
    skip_quiet();
    return out;
  }
  if (step_hold_ > 0) --step_hold_;
  double slope = push(y - step_offset_);
  const Direction stepped = model_step();
  if (stepped != phase_) slope = push_slope();  // the window without the step
  const double w = slope * s_.scan_rate_hz * kRadPerDeg;
  out.velocity_rad_s = w;
  // Direction with a dead band (hold_rad_s < move_rad_s). With the reversal window on, its slope
  // ws (lag ~(M-1)/2fs) flips flexion <-> extension as soon as it clearly sees the opposite sense,
  // the long window may only flip when ws agrees (no flip-back while it still lags), and a hold
  // needs both to be quiet (the long window passes through zero during every reversal).
  const bool fast = m_ > 0;
  const double ws = fast ? short_slope() * s_.scan_rate_hz * kRadPerDeg : 0.0;
  if (count_ < n_) {
    out.quality |= quality::kSettling;
    phase_ = Direction::kHold;  // a half-filled window is too noisy to decide a direction
  } else if (stepped != phase_) {
    phase_ = stepped;  // the step the model predicts for this change of direction
  } else if (step_hold_ > 0) {
    // A step decided the direction; the window still holds angles from before it. From half a
    // window after it, the slope of the scans since the step alone (noise 0.003 rad/s at 0.1 deg,
    // 200 Hz) may name a movement beyond reversal_rad_s in either sense: a stop taken where the
    // knee turned, or moved on with a start step too small to see.
    if (const int since = n_ - step_hold_; since >= n_ / 2) {
      const double ws_since = recent_slope(since) * s_.scan_rate_hz * kRadPerDeg;
      if (ws_since > s_.reversal_rad_s) phase_ = Direction::kFlexion;
      else if (ws_since < -s_.reversal_rad_s) phase_ = Direction::kExtension;
    }
  } else if (phase_ == Direction::kHold) {
    if (w > s_.move_rad_s) phase_ = Direction::kFlexion;
    else if (w < -s_.move_rad_s) phase_ = Direction::kExtension;
  } else if (std::abs(w) < s_.hold_rad_s && (!fast || std::abs(ws) < s_.reversal_rad_s)) {
    phase_ = Direction::kHold;
  } else if (phase_ == Direction::kFlexion &&
             (fast ? (ws < -s_.reversal_rad_s || (w < -s_.move_rad_s && ws < 0)) : w < -s_.move_rad_s)) {
    phase_ = Direction::kExtension;
  } else if (phase_ == Direction::kExtension &&
             (fast ? (ws > s_.reversal_rad_s || (w > s_.move_rad_s && ws > 0)) : w > s_.move_rad_s)) {
    phase_ = Direction::kFlexion;
  }
  out.phase = phase_;
  const double aw = std::abs(w);
  double g = 0;
  if (terms_) {
    // The paper chain inverts on the branch of `phase_`, decided ~0.25 s late (the velocity
    // window): its angle overshoots at starts, stops and reversals, and memory terms driven by it
    // (stop operators at a hold after a 2 deg overshoot back) end on the wrong side. So there the
    // terms are the quiet chain's, at the quiet angle, with this scan's velocity and direction.
    // The dynamic model's inverse decides nothing: its own chain, solved for this angle.
    if (dynamic_ || !std::isfinite(y_quiet)) g = terms_voltage(v, reference_v, w, phase_) + quiet_chain_.terms.acceleration_voltage();
    else g = quiet_chain_.terms.voltage_at(y_quiet, reference_v, w, phase_);
    if (std::isfinite(y_quiet)) commit_quiet(y_quiet, v - g_quiet, reference_v);
    else skip_quiet();
  }
  out.angle_deg = angle_of(v - g, reference_v, w, phase_, &clamped);
  if (clamped) out.quality |= quality::kAngleExtrapolated;
  if (phase_ != Direction::kHold &&
      (aw < cal_.velocity_min_rad_s * (1 - s_.velocity_tolerance) || aw > cal_.velocity_max_rad_s * (1 + s_.velocity_tolerance)))
    out.quality |= quality::kVelocityExtrapolated;
  if (out.angle_deg < cal_.angle_min_deg - s_.angle_margin_deg || out.angle_deg > cal_.angle_max_deg + s_.angle_margin_deg)
    out.quality |= quality::kAngleExtrapolated;
  return out;
}

}  // namespace pof::core
