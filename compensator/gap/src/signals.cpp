// Normalisation and kinematics for `pof gap` (see signals.hpp).
#include "pof/gap/signals.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include "pof/base/errors.hpp"
#include "pof/core/units.hpp"

namespace pof::gap {

using Eigen::Index;
using Eigen::MatrixXd;
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
  s.ref_rel = moving_mean(rec.reference_v.array() / s.reference_level_v - 1.0, static_cast<Index>(std::lround(0.5 / s.dt)));
  return s;
}

VectorXd moving_mean(const VectorXd& x, Index half) {
  const Index n = x.size();
  VectorXd cum(n + 1);
  cum(0) = 0;
  for (Index i = 0; i < n; ++i) cum(i + 1) = cum(i) + x(i);
  VectorXd out(n);
  for (Index i = 0; i < n; ++i) {
    const Index a = std::max<Index>(0, i - half), b = std::min(n, i + half + 1);
    out(i) = (cum(b) - cum(a)) / static_cast<double>(b - a);
  }
  return out;
}

VectorXd local_slope(const VectorXd& x, double dt, Index half) {
  const Index n = x.size();
  VectorXd out(n);
  // num(i) = sum_{k=-h..h} k x(i+k), the least-squares slope's numerator.
  auto direct = [&](Index i, Index h) {
    double num = 0;
    for (Index k = 1; k <= h; ++k) num += static_cast<double>(k) * (x(i + k) - x(i - k));
    return num;
  };
  auto den_of = [dt](Index h) {
    const double hh = static_cast<double>(h);
    return dt * hh * (hh + 1) * (2 * hh + 1) / 3.0;  // dt * sum_{-h..h} k^2
  };
  // Within half of either end the centred window does not fit. Its slope there is the slope of the
  // first (last) full window, held: a window shrunk to stay centred differentiates the noise of a
  // few scans (at the end, two: the potentiometer's noise times 1/dt), and differentiated twice it
  // gave an acceleration column 10-30 times the drive's largest at the recording's first and last
  // 50 ms, whose least-squares weight pulls the acceleration term's gain short, and a spurious
  // time_delay then makes up for the rest (measured: docs/gap.md, Limitations).
  if (n < 2) {
    out.setZero();
    return out;
  }
  if (n < 2 * half + 1) {
    const Index h = (n - 1) / 2;
    const double s0 = h == 0 ? (x(1) - x(0)) / dt : direct(h, h) / den_of(h);
    out.setConstant(s0);
    return out;
  }
  out.head(half + 1).setConstant(direct(half, half) / den_of(half));
  out.tail(half + 1).setConstant(direct(n - 1 - half, half) / den_of(half));
  // The interior by running sums (O(n) instead of O(n h): the search differentiates the angle once
  // per candidate delay and play): num(i+1) = num(i) - sum(i) + (h+1) x(i-h) + h x(i+h+1), with
  // sum(i) the window's plain sum; recomputed directly every 4096 scans so rounding cannot build up.
  const double den = den_of(half), hh = static_cast<double>(half);
  double num = 0, sum = 0;
  for (Index i = half; i < n - 1 - half; ++i) {
    if ((i - half) % 4096 == 0) {
      num = direct(i, half);
      sum = x.segment(i - half, 2 * half + 1).sum();
    }
    if (i > half) out(i) = num / den;
    const double leaving = x(i - half), entering = x(i + half + 1);
    num += -sum + (hh + 1) * leaving + hh * entering;
    sum += entering - leaving;
  }
  return out;
}

namespace {

// Velocity, acceleration and the hold gate of k.angle. Two differentiators: +-50 ms for the
// velocity (timing of starts/stops within ~50 ms: the model jumps by up to ~1 deg between f5 and
// eq. 11/12 at the 0.01 rad/s threshold), gated by a quiet +-125 ms one so potentiometer noise in
// holds does not flicker into "moving".
void differentiate(Kinematics& k, double dt) {
  auto half_of = [dt](double s) { return std::max<Index>(1, static_cast<Index>(std::lround(s / dt))); };
  const Index n = k.angle.size();
  k.w = local_slope(k.angle, dt, half_of(0.05)) * core::kRadPerDeg;
  const VectorXd w_quiet = local_slope(k.angle, dt, half_of(0.125)) * core::kRadPerDeg;
  k.acc = local_slope(k.w, dt, half_of(0.05));
  k.quiet_hold.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) k.quiet_hold[static_cast<std::size_t>(i)] = std::abs(w_quiet(i)) < 0.5 * kHoldSpeedRadS;
}

// The direction of movement at each scan (a hold below kHoldSpeedRadS or where the quiet
// differentiator says so) and the last movement's, kept through holds.
void compute_directions(Kinematics& k) {
  const Index n = k.angle.size();
  k.s_move.resize(n);
  k.s_last.resize(n);
  k.dir.resize(static_cast<std::size_t>(n));
  double last = 0;
  for (Index i = 0; i < n; ++i) {
    const double w = k.w(i);
    const bool hold = std::abs(w) < kHoldSpeedRadS || k.quiet_hold[static_cast<std::size_t>(i)];
    const core::Direction d = hold ? core::Direction::kHold : (w > 0 ? core::Direction::kFlexion : core::Direction::kExtension);
    k.dir[static_cast<std::size_t>(i)] = d;
    const double sm = d == core::Direction::kHold ? 0.0 : (d == core::Direction::kFlexion ? 1.0 : -1.0);
    k.s_move(i) = sm;
    if (sm != 0) last = sm;
    k.s_last(i) = last;
  }
}

}  // namespace

VectorXd paper_voltage(const Kinematics& k, const core::ModelCoefficients& m, Eigen::Ref<MatrixXd> gradient) {
  const Index n = k.angle.size();
  eigen_assert(gradient.rows() == n && gradient.cols() == core::kRefitParameters);
  VectorXd v(n);
  std::array<double, core::kRefitParameters> g{};
  for (Index i = 0; i < n; ++i) {
    v(i) = core::model_voltage_gradient(m, k.angle(i), std::abs(k.w(i)), k.dir[static_cast<std::size_t>(i)], g.data());
    for (int j = 0; j < core::kRefitParameters; ++j) gradient(i, j) = g[static_cast<std::size_t>(j)];
  }
  return v;
}

void apply_backlash(Kinematics& k, double width_deg, double dt) {
  // Belt play of width b (the play operator of half-width b/2, pof/core/dynamic_model.hpp): while the
  // joint moves, the potentiometer follows it b/2 behind, so the joint is ref + s b/2 with s the
  // direction of the last movement, kept through holds. At a reversal the joint turns at the
  // reference's extreme phi_p and crosses the band while the reference stands; the reference
  // leaves phi_p once the joint is b past its turning point, and from then on moves with the
  // joint. Offline the whole reversal is in view, so the crossing is rebuilt backwards from the
  // reference's departure (docs/gap.md, section 3): the departure gives the time t_r at which the
  // joint had crossed and its speed v1 then, the approach gives the shape of the turn, and the
  // joint's travel over the crossing has that shape, starts at speed 0 and covers b by t_r.
  // A crossing at a constant speed (the departure's mean over its first 0.3 s) is too short for a
  // turn that starts from rest, half as long as a gait's, and the error it leaves at every reversal
  // is taken up by a spurious time_delay (measured: docs/gap.md, section 3, "The joint behind a
  // belt's play"). A flip of the velocity's sign with no departure of the reference
  // (potentiometer noise in a long hold) is not a reversal: the joint keeps its side of the band.
  const Index n = k.angle.size();
  const double half = width_deg / 2;
  const VectorXd ref = k.angle;
  for (Index i = 0; i < n; ++i) k.angle(i) = ref(i) + k.s_last(i) * half;
  // Above the smoothed potentiometer's noise: "the reference has left its plateau".
  constexpr double kPlateauDeg = 0.05;
  const auto span = std::max<Index>(3, static_cast<Index>(std::lround(0.15 / dt)));
  auto t_of = [dt](Index i) { return static_cast<double>(i) * dt; };
  for (Index i1 = 1; i1 < n; ++i1) {
    const double s_new = k.s_move(i1), s_old = k.s_last(i1 - 1);
    if (s_new == 0 || k.s_move(i1 - 1) == s_new || s_old != -s_new) continue;
    Index ia = i1 - 1;  // the old movement's last scan
    while (ia > 0 && k.s_move(ia) == 0) --ia;
    Index i_back = i1;  // where the old direction comes back, if it does
    while (i_back < n && k.s_move(i_back) != s_old) ++i_back;
    // The plateau: the reference's extreme around the turn, levelled over the scans near it.
    const Index w_end = std::min(i_back, i1 + span);
    double extreme = s_old * ref(ia);
    for (Index i = ia; i < w_end; ++i) extreme = std::max(extreme, s_old * ref(i));
    std::vector<double> level;
    for (Index i = ia; i < w_end; ++i)
      if (extreme - s_old * ref(i) < kPlateauDeg) level.push_back(ref(i));
    std::nth_element(level.begin(), level.begin() + static_cast<std::ptrdiff_t>(level.size() / 2), level.end());
    const double phi_p = level[level.size() / 2];
    Index i_stop = std::max<Index>(0, ia - span);
    while (i_stop < i1 && std::abs(ref(i_stop) - phi_p) >= kPlateauDeg) ++i_stop;
    // The departure: the reference clearly away (4x the plateau's width), then back to where it
    // left the plateau, so one noisy scan past the plateau's edge is not taken for it.
    Index i_first = i_stop;
    while (i_first < i_back && s_new * (ref(i_first) - phi_p) <= 4 * kPlateauDeg) ++i_first;
    while (i_first > i_stop && s_new * (ref(i_first - 1) - phi_p) > kPlateauDeg) --i_first;
    if (i_first >= i_back || i_first + 3 > n) {
      // No departure before the old direction resumes: noise, not a reversal.
      for (Index i = i1; i < i_back; ++i) k.angle(i) = ref(i) + s_old * half;
      continue;
    }
    // The departure: a least-squares quadratic D = d0 + v tau + a tau^2 / 2 through it gives the
    // time t_r at which the joint had crossed and its speed v1 then. It spans the departure's
    // first 2b (at least 0.3 deg, well clear of the noise; between 0.05 and 1 s), so a slow one
    // is seen over a distance and not over a fixed time in which it hardly moves.
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Eigen::Vector3d aty = Eigen::Vector3d::Zero();
    Index fit_end = std::min(n, i_first + std::max<Index>(3, static_cast<Index>(std::lround(0.05 / dt))));
    const Index fit_max = std::min(n, i_first + static_cast<Index>(std::lround(1.0 / dt)));
    while (fit_end < fit_max && s_new * (ref(fit_end) - phi_p) < std::max(2 * width_deg, 0.3)) ++fit_end;
    for (Index i = i_first; i < fit_end; ++i) {
      const double tau = t_of(i) - t_of(i_first);
      const Eigen::Vector3d row(1.0, tau, 0.5 * tau * tau);
      ata += row * row.transpose();
      aty += row * (s_new * (ref(i) - phi_p));
    }
    const Eigen::Vector3d q = ata.ldlt().solve(aty);
    const double a1 = std::max(0.0, q(2));
    const double tau_r = q(1) > 0 ? std::clamp(-q(0) / q(1), -t_of(i_first - i_stop), 0.0) : 0.0;
    double v1 = q(1) + a1 * tau_r;
    if (!(v1 > 0)) v1 = (s_new * (ref(fit_end - 1) - phi_p)) / std::max(dt, t_of(fit_end - 1) - t_of(i_first));
    if (!(v1 > 0)) continue;
    // The crossing lasts T = r b / v1, with r read off the approach, mirrored: the reference shows
    // how the joint came into its turn, and over its last b it took r b / v_b (v_b its speed b
    // before the turn): r = 1 for a stop from cruising speed, 2 for a constant deceleration (a
    // gait's turn), up to 3 for a gentler one. Measured between b and b/4 before the plateau, clear
    // of its noise, where a stop from cruising speed takes 0.75 b / v_b and a constant
    // deceleration b / v_b. A turn that leaves unlike it came in (a hold ended by a gait's cosine
    // after a ramp at constant speed) is off by up to the play's half-width for a few scans.
    double r = 2;
    {
      Index iq = i_stop;
      while (iq > ia - 5 * span && iq > 0 && s_old * (phi_p - ref(iq)) < width_deg / 4) --iq;
      Index ib = iq;
      while (ib > ia - 5 * span && ib > 0 && s_old * (phi_p - ref(ib)) < width_deg) --ib;
      const double v_b = std::abs(k.w(ib)) * 180.0 / std::numbers::pi;
      if (ib > 0 && ib > ia - 5 * span && s_old * (phi_p - ref(ib)) >= width_deg && v_b > 0) {
        const double rho = (t_of(iq) - t_of(ib)) * v_b / width_deg;
        r = std::clamp(1 + 4 * (rho - 0.75), 1.0, 3.0);
      }
    }
    const double t_r = t_of(i_first) + tau_r;
    // The joint cannot turn before the reference stopped.
    const double T = std::min(r * width_deg / v1, t_r - t_of(i_stop));
    if (!(T > 0)) continue;
    const double t0 = t_r - T;
    // The joint's travel from its turn, D / (v1 T) at s = (t - t0) / T, from 0 at speed 0 to r^-1
    // at speed v1: for r <= 2 a constant acceleration over the share beta of T, then cruising; for
    // r > 2 a speed quadratic in s, v1 (alpha s + (1 - alpha) s^2).
    const double beta = 2 * (1 - 1 / std::min(r, 2.0)), alpha = 6 / std::max(r, 2.0) - 2;
    auto travel = [&](double x) {
      if (r > 2) return x * x * (alpha / 2 + (1 - alpha) * x / 3);
      return x < beta ? x * x / (2 * beta) : x - beta / 2;
    };
    const double scale = width_deg / travel(1.0);  // exactly b at t_r, also when T was cut short
    const double theta_turn = phi_p + s_old * half;
    for (Index i = std::min(i_stop, i1); i < std::max(i_first, i1); ++i) {
      const double t = t_of(i);
      if (t < t0) k.angle(i) = ref(i) + s_old * half;
      else if (t < t_r) k.angle(i) = theta_turn + s_new * scale * travel((t - t0) / T);
      else k.angle(i) = ref(i) + s_new * half;
    }
  }
  // The joint's own velocity, acceleration and holds: it moves while the reference stands.
  differentiate(k, dt);
  compute_directions(k);
}

Kinematics make_kinematics(const VectorXd& angle, double dt, double delay_s) {
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
  differentiate(k, dt);
  compute_directions(k);
  return k;
}

}  // namespace pof::gap
