#include "pof/core/compensator.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "pof/core/units.hpp"

namespace pof::core {

OnlineCompensator::OnlineCompensator(const Calibration& cal, const CompensatorSettings& s) : cal_(cal), s_(s) {
  if (!(s.scan_rate_hz > 0) || !(s.velocity_window_s > 0))
    throw std::invalid_argument("compensator: scan_rate_hz and velocity_window_s must be > 0");
  if (!(s.hold_rad_s >= 0) || !(s.hold_rad_s < s.move_rad_s))
    throw std::invalid_argument("compensator: need 0 <= hold_rad_s < move_rad_s (the dead band)");
  if (!(cal.reference_level_v > 0)) throw std::invalid_argument("compensator: reference level must be > 0");
  // Counted in double first: a window of 1e9 s at 200 Hz does not fit an int (it wrapped to a
  // 2-scan window once).
  const double scans = std::round(s.velocity_window_s * s.scan_rate_hz);
  if (!(scans <= 1'000'000)) throw std::invalid_argument("compensator: velocity window too long");
  const int n = std::max(2, static_cast<int>(scans));
  window_ = VelocityWindow(n);
  int reversal_scans = 0;
  if (s.reversal_window_s > 0) {
    if (!(s.reversal_rad_s > s.move_rad_s))
      throw std::invalid_argument("compensator: reversal_rad_s must exceed move_rad_s");
    if (!(s.reversal_window_s <= s.velocity_window_s))
      throw std::invalid_argument("compensator: reversal_window_s must not exceed velocity_window_s");
    reversal_scans = std::clamp(static_cast<int>(std::lround(s.reversal_window_s * s.scan_rate_hz)), 2, n);
  }
  direction_ = DirectionDetector(s, reversal_scans);
  if (s.model_steps && cal.active != ModelKind::kDynamic && s.velocity_source == VelocitySource::kSensor)
    steps_ = StepDetector(cal.model, cal.velocity_min_rad_s, s, n);
  if (cal.active == ModelKind::kDynamic) {
    if (!cal.dynamic) throw std::invalid_argument("compensator: the dynamic model is selected but the calibration has none");
    if (const char* why = cal.dynamic->invalid_reason(); *why != '\0')
      throw std::invalid_argument(std::string("compensator: dynamic model: ") + why);
    dynamic_ = true;
    if (s.estimate && cal.estimator) {
      if (const char* why = cal.estimator->invalid_reason(); *why != '\0')
        throw std::invalid_argument(std::string("compensator: estimator: ") + why);
      if (!(s.estimator_lag_s >= 0) || !(s.estimator_lag_s * s.scan_rate_hz <= kMaxSmootherLag))
        throw std::invalid_argument("compensator: estimator_lag_s must be within 0.." +
                                    std::to_string(kMaxSmootherLag / s.scan_rate_hz) + " s at this scan rate");
      if (s.estimator_lag_s > 0 && cal.gap && !cal.gap->empty())
        throw std::invalid_argument("compensator: estimator_lag_s cannot be combined with [gap] terms");
      estimating_ = true;
      lag_ = static_cast<int>(std::lround(s.estimator_lag_s * s.scan_rate_hz));
      estimator_ = AngleEstimator(*cal.dynamic, *cal.estimator, s.scan_rate_hz, lag_);
    } else {
      inverter_ = DynamicInverter(*cal.dynamic, s.scan_rate_hz);  // the per-scan inverse: older files, `invert`
    }
  }
  if (s.estimator_lag_s != 0 && !estimating_)
    throw std::invalid_argument("compensator: estimator_lag_s needs the dynamic model's angle estimated (an active [dynamic] "
                                "with [estimator], and estimate on)");
  if (cal.gap && !cal.gap->empty()) {
    if (const auto problems = gap_problems(*cal.gap, s.scan_rate_hz); !problems.empty())
      throw std::invalid_argument("compensator: " + problems.front().describe());
    terms_ = TermChains(cal, s.scan_rate_hz, dynamic_);
  }
  guard_.level_v = cal.reference_level_v;
  guard_.min_ratio = s.reference_min_ratio;
  guard_.max_ratio = s.reference_max_ratio;
  guard_.min_abs_v = s.reference_min_v;
}

void OnlineCompensator::clear_window() noexcept {
  window_.clear();
  direction_.clear();
  steps_.clear();
}

void OnlineCompensator::reset() noexcept {
  clear_window();
  inverter_.reset();  // the memory of the lost scans is unknown: start from a relaxed state
  estimator_.reset();
  stored_ = 0;
  terms_.reset();
  scans_lost_ = true;
}

double OnlineCompensator::angle_of(double v, double reference_v, double w, Direction d, CompensatedScan& out) noexcept {
  double angle = 0;
  if (estimating_) {
    const AngleEstimator::Result r = estimator_.step(v);
    estimate_ = r;
    angle = r.angle_deg;
    out.angle_sigma_deg = r.sigma_deg;
    if (r.clamped) out.quality |= quality::kAngleExtrapolated;
    if (r.restarted) out.quality |= quality::kSettling;
  } else if (dynamic_) {
    const DynamicInverter::Result r = inverter_.step(v);
    angle = r.angle_deg;
    if (r.clamped) out.quality |= quality::kAngleExtrapolated;
  } else {
    angle = compensated_angle(cal_.model, v, std::abs(w), d);  // f5 alone in holds
  }
  return terms_.active() ? terms_.reference_angle(angle, v, reference_v) : angle;
}

double OnlineCompensator::delay_s() const noexcept { return (window_.size() - 1) / (2.0 * s_.scan_rate_hz); }

double OnlineCompensator::velocity_noise_rad_s(double angle_noise_deg) const noexcept {
  const double n = window_.size();
  return angle_noise_deg * std::sqrt(12.0 / (n * (n * n - 1))) * s_.scan_rate_hz * kRadPerDeg;
}

CompensatedScan OnlineCompensator::step(double sensor_v, double reference_v, double angle_ref_deg) noexcept {
  const CompensatedScan now = step_now(sensor_v, reference_v, angle_ref_deg);
  return lag_ > 0 ? delayed(now) : now;
}

// With a fixed lag the estimator's angle is the scan lag_ back's: the rest of that scan's record
// comes from the ring, so that every field of the output is of one scan.
CompensatedScan OnlineCompensator::delayed(const CompensatedScan& now) noexcept {
  head_ = head_ == lag_ ? 0 : head_ + 1;
  ring_[static_cast<std::size_t>(head_)] = now;
  if (stored_ <= lag_) ++stored_;
  const double nan = std::nan("");
  if (stored_ <= lag_) {  // no scan lag_ back yet
    CompensatedScan none;
    none.angle_deg = none.angle_uncomp_deg = none.velocity_rad_s = nan;
    none.quality = quality::kSettling;
    return none;
  }
  CompensatedScan out = ring_[static_cast<std::size_t>(head_ == lag_ ? 0 : head_ + 1)];  // the oldest
  const bool usable = (out.quality & (quality::kInvalidInput | quality::kReferenceLost)) == 0;
  out.angle_deg = usable ? estimate_.angle_deg : nan;
  out.angle_sigma_deg = usable ? estimate_.sigma_deg : nan;
  if (usable && !std::isfinite(estimate_.angle_deg)) out.quality |= quality::kSettling;  // restarted since
  flag_angle_range(out);
  return out;
}

CompensatedScan OnlineCompensator::step_now(double sensor_v, double reference_v, double angle_ref_deg) noexcept {
  CompensatedScan out;
  terms_.begin_scan();
  if (scans_lost_) {
    out.quality |= quality::kScansLost;
    scans_lost_ = false;
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
    // must not span the scans it never saw (docs/calibration.md, "The dynamic model").
    if (estimating_) estimate_ = estimator_.step(nan);  // the time passes: a prediction without a voltage
    else if (dynamic_) inverter_.step(nan);
    if (terms_.active()) terms_.interrupt();
    return out;
  }
  out.angle_uncomp_deg = quasi_static_angle(cal_.model, nz.v);
  // [gap] periodic interference is notched out before either model sees the voltage.
  const double v = terms_.active() ? terms_.filter(nz.v) : nz.v;
  // With [gap] terms the velocity is estimated on the quiet angle (term_chains.hpp): never on an
  // angle that went through the direction it is to decide.
  double g_quiet = 0;
  const double y_quiet = terms_.active() ? terms_.quiet_angle(v, reference_v, &g_quiet) : out.angle_uncomp_deg;
  if (terms_.active() && !std::isfinite(y_quiet)) terms_.interrupt_quiet();
  const double y = s_.velocity_source == VelocitySource::kReference ? angle_ref_deg : y_quiet;
  if (!std::isfinite(y)) {
    out.quality |= quality::kInvalidInput | quality::kSettling;
    // The dynamic model needs no velocity; the paper's falls back to f5 without one.
    const double g = terms_.active() ? terms_.published_chain_voltage(v, reference_v, nan, Direction::kHold) : 0.0;
    CompensatedScan unflagged;  // settling already says it all
    out.angle_deg = angle_of(v - g, reference_v, nan, Direction::kHold, unflagged);
    out.angle_sigma_deg = unflagged.angle_sigma_deg;
    out.velocity_rad_s = nan;
    clear_window();
    terms_.skip_quiet();
    return out;
  }
  // The velocity, a model step taken out of its window, and the direction.
  steps_.tick();
  double slope = window_.push(y - steps_.offset());
  const Direction stepped = steps_.detect(window_, direction_.phase());
  if (stepped != direction_.phase()) slope = window_.slope();  // the window without the step
  const double w = slope * s_.scan_rate_hz * kRadPerDeg;
  out.velocity_rad_s = w;
  if (!window_.full()) out.quality |= quality::kSettling;
  const Direction phase = direction_.update(window_, w, stepped, steps_.hold());
  out.phase = phase;
  // The terms' voltage for the published angle, then the quiet chain takes this scan's angle.
  double g = 0;
  if (terms_.active()) {
    g = terms_.published_voltage(v, reference_v, y_quiet, w, phase);
    if (std::isfinite(y_quiet)) terms_.commit_quiet(y_quiet, v - g_quiet, reference_v, phase);
    else terms_.skip_quiet();
  }
  out.angle_deg = angle_of(v - g, reference_v, w, phase, out);
  const double aw = std::abs(w);
  if (phase != Direction::kHold &&
      (aw < cal_.velocity_min_rad_s * (1 - s_.velocity_tolerance) || aw > cal_.velocity_max_rad_s * (1 + s_.velocity_tolerance)))
    out.quality |= quality::kVelocityExtrapolated;
  // With a fixed lag this scan's angle is another scan's: delayed() judges the one it publishes.
  if (lag_ == 0) flag_angle_range(out);
  return out;
}

void OnlineCompensator::flag_angle_range(CompensatedScan& out) const noexcept {
  if (out.angle_deg < cal_.angle_min_deg - s_.angle_margin_deg || out.angle_deg > cal_.angle_max_deg + s_.angle_margin_deg)
    out.quality |= quality::kAngleExtrapolated;
}

}  // namespace pof::core
