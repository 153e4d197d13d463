#include "pof/core/term_chains.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "pof/core/calibration.hpp"
#include "pof/core/effects.hpp"

namespace pof::core {

TermChains::TermChains(const Calibration& cal, double scan_rate_hz, bool dynamic)
    : active_(true), dynamic_(dynamic), model_(cal.model) {
  if (dynamic) dynamic_model_ = *cal.dynamic;
  quiet_.terms = GapCorrector(cal, scan_rate_hz);
  // The acceleration is estimated once, on the quiet angle, for both chains: the published angle
  // goes through the active model's inverse, whose bend-lag inverse (theta_f + tau_b theta_f')
  // differentiates it once more, so an acceleration estimated on that angle and subtracted before
  // it closes a loop through a third derivative, which rings (docs/calibration.md, "[gap]", step 4).
  GapModel published = *cal.gap;
  std::erase_if(published.terms, [](const GapTerm& t) { return effect_of(t.effect) == Effect::kAccelerationDependence; });
  Calibration without_acceleration = cal;
  without_acceleration.gap = std::move(published);
  published_.terms = GapCorrector(without_acceleration, scan_rate_hz);
  if (dynamic && cal.gap->backlash_deg > 0) {
    play_inverter_ = DynamicInverter(*cal.dynamic, scan_rate_hz);
    play_inverse_ = true;
  }
}

void TermChains::reset() noexcept {
  play_inverter_.reset();
  published_.restart();
  quiet_.restart();
}

void TermChains::interrupt() noexcept {
  published_.terms.interrupt();
  quiet_.terms.interrupt();
  skip_quiet();
}

double TermChains::published_chain_voltage(double v, double reference_v, double w, Direction d) const noexcept {
  const double guess = std::isfinite(published_.angle) ? published_.angle : quasi_static_angle(model_, v);
  return solve_voltage(published_, v, reference_v, w, d, model_slope(guess, w, d));
}

double TermChains::published_voltage(double v, double reference_v, double y, double w, Direction d) const noexcept {
  // The paper chain inverts on the branch of the direction, decided ~0.25 s late: its angle
  // overshoots at starts, stops and reversals, and memory terms driven by it end on the wrong side.
  // So there the terms are the quiet chain's, at the quiet angle. The dynamic model's inverse
  // decides nothing: its own chain, solved for this angle (docs/calibration.md, "[gap]", step 4).
  if (dynamic_ || !std::isfinite(y)) return published_chain_voltage(v, reference_v, w, d) + quiet_.terms.acceleration_voltage();
  return quiet_.terms.voltage_at(y, reference_v, w, d);
}

double TermChains::quiet_angle(double v, double reference_v, double* g) const noexcept {
  // f5 is the hold's model (dA/dv = -c9 everywhere) and this angle decides the direction: the
  // terms that switch with it (rate_dependent_hysteresis) are off here, as in a hold.
  *g = solve_voltage(quiet_, v, reference_v, 0.0, Direction::kHold, -model_.c9);
  return quasi_static_angle(model_, v - *g);
}

void TermChains::commit_quiet(double angle, double u, double reference_v, Direction phase) noexcept {
  quiet_.angle = angle;
  quiet_.u = u;
  quiet_committed_ = true;
  const double play_angle = play_inverse_ ? play_inverter_.step(u).angle_deg : std::nan("");
  // On the paper chain a positive delay is not extrapolated while the direction is a hold: there
  // the quiet angle's slope is mostly that of the step f5 makes as the sensor leaves its branch at
  // a stop (eqs. (11)/(12)), which the fit window would carry into the hold (step 6).
  const bool extrapolate = dynamic_ || phase != Direction::kHold;
  // f5's slope reconstructs the angle without the acceleration term for its own window.
  quiet_.terms.advance(angle, reference_v, quiet_.terms.has_acceleration() ? -model_.c9 : 0.0, play_angle, extrapolate);
}

void TermChains::skip_quiet() noexcept {
  // The play's inverse has no angle this scan: its bend-lag window must not span the lost scans.
  if (play_inverse_) play_inverter_.step(std::nan(""));
}

double TermChains::reference_angle(double angle, double v, double reference_v) noexcept {
  if (!std::isfinite(angle)) {
    published_.terms.interrupt();
    return angle;
  }
  published_.angle = angle;
  published_.u = v;
  const double own = published_.terms.advance(angle, reference_v, 0.0);  // delay and backlash undone
  if (!quiet_committed_) return own;
  // The velocity extrapolation's slope and the play's side come from the quiet chain, which ran
  // the same kinematics on the quiet angle this scan; a negative delay (the angle |d| ago) is
  // exact on this angle and stays its own.
  const GapCorrector::Kinematics& q = quiet_.terms.last_kinematics();
  const double joint = published_.terms.extrapolates() ? angle + (q.joint - q.angle) : published_.terms.last_kinematics().joint;
  return joint + (q.reference - q.joint);
}

double TermChains::solve_voltage(const Chain& c, double v, double reference_v, double w, Direction d,
                                 double slope) const noexcept {
  const double guess = std::isfinite(c.angle) ? c.angle : quasi_static_angle(model_, v);
  const double g0 = c.terms.voltage_at(guess, reference_v, w, d);
  if (!std::isfinite(c.angle) || !std::isfinite(c.u)) return g0;
  // This scan's A solves F(A) = A - A0 - s (v - g(A) - u_prev) = 0, F' = 1 + s g', the model
  // linearised at the previous angle A0 (slope s = dA/dv), the terms exact. A fixed point at A0
  // alone oscillates and grows once |s g'| > 1, and one Newton step overshoots across the kink of
  // a stop or play operator; so Newton steps with the slope of the side they move to until F
  // changes sign, then regula falsi (Illinois) closes the bracket. The step's divisor is held at
  // kMinDivisor where the terms nearly cancel the model's slope (docs/calibration.md, "[gap]", step 2).
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
  for (int it = 0; it < kSearchSteps && fb != 0; ++it) {
    const double dir = fb > 0 ? -1.0 : 1.0;
    const double g1 = c.terms.voltage_at(b + dir * kSlopeStepDeg, reference_v, w, d);
    const double dfdA = 1.0 + slope * (g1 - gb) / (dir * kSlopeStepDeg);
    const double next = b - fb / std::max(std::isfinite(dfdA) ? dfdA : 1.0, kMinDivisor);
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
  for (int it = 0; it < kSearchSteps && std::abs(b - a) > kTolDeg; ++it) {
    const double m = (a * fb - b * fa) / (fb - fa);
    const double fm = F(m);
    if (!std::isfinite(fm)) break;
    if (fm == 0) return gval;
    if ((fm > 0) == (fb > 0)) { b = m; fb = fm; rb = std::abs(fm); gb = gval; if (side == -1) fa /= 2; side = -1; }
    else { a = m; fa = fm; ra = std::abs(fm); ga = gval; if (side == 1) fb /= 2; side = 1; }
  }
  return ra < rb ? ga : gb;
}

double TermChains::model_slope(double angle, double w, Direction d) const noexcept {
  // f3..f5 are affine in v (f5 alone in holds); the dynamic model's quasi-static slope (its loop's
  // is small).
  if (dynamic_) return 1.0 / dynamic_model_->quasi_static_slope(angle);
  if (d == Direction::kHold) return -model_.c9;
  const DirectionCoefficients& x = model_.of(d);
  return -model_.c9 * x.c7 * f3_line(model_, x, std::abs(w)).a;
}

}  // namespace pof::core
