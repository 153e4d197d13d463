// Normalisation and kinematics for `pof gap` (see signals.hpp).
#include "pof/gap/signals.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include "pof/base/errors.hpp"



namespace pof::gap {

using Eigen::Index;
using Eigen::VectorXd;

namespace {

double median(VectorXd x) {
  std::vector<double> s(x.data(), x.data() + x.size());
  auto mid = s.begin() + static_cast<std::ptrdiff_t>(s.size() / 2);
  std::nth_element(s.begin(), mid, s.end());
  return *mid;
}

// Centred quadratic least squares over +-h (Savitzky & Golay 1964, Anal. Chem. 36: 1627-1639),
// evaluated at the centre; the window shrinks symmetrically at the ends.
VectorXd smooth_quadratic(const VectorXd& x, Index half) {
  const Index n = x.size();
  VectorXd out(n);
  for (Index i = 0; i < n; ++i) {
    const Index h = std::min({half, i, n - 1 - i});
    if (h < 2) { out(i) = x(i); continue; }
    // Weights of the quadratic fit at the centre: (3(3h^2 + 3h - 1) - 15 k^2) / ((2h-1)(2h+1)(2h+3)).
    const double hh = static_cast<double>(h);
    const double den = (2 * hh - 1) * (2 * hh + 1) * (2 * hh + 3);
    double acc = 0;
    for (Index k = -h; k <= h; ++k) {
      const double kk = static_cast<double>(k);
      acc += (3 * (3 * hh * hh + 3 * hh - 1) - 15 * kk * kk) / den * x(i + k);
    }
    out(i) = acc;
  }
  return out;
}

}  // namespace

Signals make_signals(const io::Recording& rec) {
  const std::string src = rec.source.empty() ? std::string("recording") : rec.source;
  const Index n = rec.size();
  if (rec.angle_ref_deg.size() != n)
    throw pof::DataError(src + ": column angle_ref_deg is required (a pot_v-only recording needs a potentiometer "
                              "calibration first: run `pof compensate`/`pof calibrate` to get angle_ref_deg)");
  if (rec.sensor_v.size() != n || rec.reference_v.size() != n)
    throw pof::DataError(src + ": columns sensor_v and reference_v must have one value per scan");
  // The blocked cross-validation needs several whole cycles; 60 s is about one slow calibration sweep.
  if (n < 200 || rec.t_s(n - 1) - rec.t_s(0) < 60.0)
    throw pof::DataError(src + ": recording too short for `pof gap` (" + std::to_string(n) +
                        " scans); need at least 60 s containing holds and movements");
  Signals s;
  s.n = n;
  s.dt = (rec.t_s(n - 1) - rec.t_s(0)) / static_cast<double>(n - 1);
  if (!(s.dt > 0)) throw pof::DataError(src + ": column t_s is not increasing");
  for (Index i = 1; i < n; ++i) {
    const double d = rec.t_s(i) - rec.t_s(i - 1);
    // Recordings come at any constant rate: tolerate timestamp jitter, not gaps or reordering.
    if (!(d > 0.5 * s.dt && d < 1.5 * s.dt))
      throw pof::DataError(src + ": data row " + std::to_string(i + 1) + ": t_s step " + std::to_string(d) +
                          " s, expected a constant rate with period " + std::to_string(s.dt) + " s");
  }
  for (Index i = 0; i < n; ++i)
    if (!(rec.reference_v(i) > 0) || !std::isfinite(rec.sensor_v(i)) || !std::isfinite(rec.angle_ref_deg(i)))
      throw pof::DataError(src + ": data row " + std::to_string(i + 1) +
                          ": expected finite values and reference_v > 0 (the normalisation divides by it)");
  s.reference_level_v = median(rec.reference_v);
  s.t = rec.t_s.array() - rec.t_s(0);
  s.v = rec.sensor_v.array() * (s.reference_level_v / rec.reference_v.array());
  // The model's input: the reference angle through a centred quadratic Savitzky-Golay filter over
  // +-25 ms (-3 dB near 25 Hz at any rate). The knee cannot move at the frequencies it removes, so
  // what it removes is the potentiometer's noise and pick-up; left in, mains on the reference
  // channel becomes 60 Hz in the model voltage, which a fractional time_delay (its linear
  // interpolation is a low-pass filter) then "explains".
  s.angle = smooth_quadratic(rec.angle_ref_deg, std::max<Index>(1, static_cast<Index>(std::lround(0.025 / s.dt))));
  // The light source wanders slowly (seconds to minutes); a centred 1 s mean keeps that and drops
  // the reference channel's own noise, which the per-scan normalisation already passes into v and
  // which must not pass for "source power coupling".
  {
    const VectorXd rel = rec.reference_v.array() / s.reference_level_v - 1.0;
    const auto half = static_cast<Index>(std::lround(0.5 / s.dt));
    VectorXd cum(n + 1);
    cum(0) = 0;
    for (Index i = 0; i < n; ++i) cum(i + 1) = cum(i) + rel(i);
    s.ref_rel.resize(n);
    for (Index i = 0; i < n; ++i) {
      const Index a = std::max<Index>(0, i - half), b = std::min(n, i + half + 1);
      s.ref_rel(i) = (cum(b) - cum(a)) / static_cast<double>(b - a);
    }
  }
  return s;
}

VectorXd local_slope(const VectorXd& x, double dt, Index half) {
  const Index n = x.size();
  VectorXd out(n);
  for (Index i = 0; i < n; ++i) {
    // Shrink the window symmetrically at the ends so the fit stays centred.
    const Index h = std::min({half, i, n - 1 - i});
    if (h == 0) {
      out(i) = n > 1 ? (i == 0 ? x(1) - x(0) : x(i) - x(i - 1)) / dt : 0.0;
      continue;
    }
    double num = 0;
    for (Index k = 1; k <= h; ++k) num += static_cast<double>(k) * (x(i + k) - x(i - k));
    const double hh = static_cast<double>(h);
    const double den = dt * hh * (hh + 1) * (2 * hh + 1) / 3.0;  // dt * sum_{-h..h} k^2
    out(i) = num / den;
  }
  return out;
}

void compute_factors(Kinematics& k, const core::ModelCoefficients& m) {
  const Index n = k.angle.size();
  k.s_move.resize(n);
  k.s_last.resize(n);
  k.dir.resize(static_cast<std::size_t>(n));
  k.v0.resize(n);
  k.gradient.resize(n, core::kRefitParameters);
  std::array<double, core::kRefitParameters> g{};
  double last = 0;
  for (Index i = 0; i < n; ++i) {
    const double w = k.w(i), aw = std::abs(w);
    const bool hold = aw < kHoldSpeedRadS || k.quiet_hold[static_cast<std::size_t>(i)];
    const core::Direction d = hold ? core::Direction::kHold : (w > 0 ? core::Direction::kFlexion : core::Direction::kExtension);
    k.dir[static_cast<std::size_t>(i)] = d;
    const double sm = d == core::Direction::kHold ? 0.0 : (d == core::Direction::kFlexion ? 1.0 : -1.0);
    k.s_move(i) = sm;
    if (sm != 0) last = sm;
    k.s_last(i) = last;
    k.v0(i) = core::model_voltage_gradient(m, k.angle(i), aw, d, g.data());
    for (int j = 0; j < core::kRefitParameters; ++j) k.gradient(i, j) = g[static_cast<std::size_t>(j)];
  }
}

void apply_backlash(Kinematics& k, double width_deg, double dt, const core::ModelCoefficients& m) {
  // Belt play of width b (play operator): the potentiometer follows the joint only once the dead
  // band is taken up. While moving, the joint leads the reference by b/2 in the direction of motion
  // and keeps that lead through the following hold; at a reversal the reference stands still while
  // the joint crosses the band (b / speed seconds), which the reference calls a hold. Offline we see
  // the reversal coming, so those scans get the joint's motion back: moving at the speed of the
  // following movement, from ref + s_old b/2 to ref + s_new b/2.
  const Index n = k.angle.size();
  constexpr double kDeg = 180.0 / std::numbers::pi;
  const VectorXd ref = k.angle;
  for (Index i = 0; i < n; ++i) k.angle(i) = ref(i) + k.s_last(i) * width_deg / 2;
  for (Index i1 = 1; i1 < n; ++i1) {
    const double s_new = k.s_move(i1), s_old = k.s_last(i1 - 1);
    if (s_new == 0 || k.s_move(i1 - 1) == s_new || s_old != -s_new) continue;
    const Index span = std::min<Index>(n - i1, std::max<Index>(1, static_cast<Index>(0.3 / dt)));
    double v = 0;
    for (Index j = i1; j < i1 + span; ++j) v += std::abs(k.w(j));
    v = v / static_cast<double>(span) * kDeg;  // deg/s
    if (!(v > 0)) continue;
    const auto n_db = static_cast<Index>(std::lround(width_deg / v / dt));
    for (Index j = i1 - 1; j >= std::max<Index>(0, i1 - n_db) && k.s_move(j) == 0; --j) {
      const double travelled_back = static_cast<double>(i1 - j) * dt * v;  // deg still to cross at j
      k.angle(j) = ref(j) + s_new * width_deg / 2 - s_new * travelled_back;
      k.w(j) = s_new * v / kDeg;
      k.quiet_hold[static_cast<std::size_t>(j)] = false;
    }
  }
  compute_factors(k, m);
}

Kinematics make_kinematics(const VectorXd& angle, double dt, double delay_s, const core::ModelCoefficients& m) {
  const Index n = angle.size();
  Kinematics k;
  if (delay_s == 0.0) {
    k.angle = angle;
  } else {
    k.angle.resize(n);
    const double shift = delay_s / dt;
    for (Index i = 0; i < n; ++i) {
      const double x = std::clamp(static_cast<double>(i) - shift, 0.0, static_cast<double>(n - 1));
      const auto i0 = static_cast<Index>(std::floor(x));
      const Index i1 = std::min(i0 + 1, n - 1);
      const double f = x - static_cast<double>(i0);
      k.angle(i) = (1 - f) * angle(i0) + f * angle(i1);
    }
  }
  // Two differentiators: +-50 ms for the velocity (timing of starts/stops within ~50 ms: the model
  // jumps by up to ~1 deg between f5 and eq. 11/12 at the 0.01 rad/s threshold), gated by a quiet
  // +-125 ms one so potentiometer noise in holds does not flicker into "moving".
  auto half_of = [dt](double s) { return std::max<Index>(1, static_cast<Index>(std::lround(s / dt))); };
  constexpr double kRad = std::numbers::pi / 180.0;
  k.w = local_slope(k.angle, dt, half_of(0.05)) * kRad;
  const VectorXd w_quiet = local_slope(k.angle, dt, half_of(0.125)) * kRad;
  k.acc = local_slope(k.w, dt, half_of(0.05));
  k.quiet_hold.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) k.quiet_hold[static_cast<std::size_t>(i)] = std::abs(w_quiet(i)) < 0.5 * kHoldSpeedRadS;
  compute_factors(k, m);
  return k;
}

}  // namespace pof::gap
