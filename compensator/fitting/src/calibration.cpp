#include "pof/core/calibration.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "pof/base/format.hpp"
#include "pof/core/normalise.hpp"

namespace pof::core {

namespace {

std::string signed_term(double x, int digits) { return (x < 0 ? " - " : " + ") + format_significant(std::abs(x), digits); }

// Finite (x, y) pairs of samples [b, e) where mask holds, appended.
void append_finite(std::vector<double>& xs, std::vector<double>& ys, const Eigen::VectorXd& x,
                   const Eigen::VectorXd& y, Eigen::Index b, Eigen::Index e) {
  for (Eigen::Index i = b; i < e; ++i)
    if (std::isfinite(x(i)) && std::isfinite(y(i))) {
      xs.push_back(x(i));
      ys.push_back(y(i));
    }
}

Eigen::Map<const Eigen::VectorXd> as_vec(const std::vector<double>& v) {
  return {v.data(), static_cast<Eigen::Index>(v.size())};
}

}  // namespace

CalibrationResult calibrate(const Eigen::VectorXd& t_s, const Eigen::VectorXd& sensor_v,
                            const Eigen::VectorXd& reference_v, const Eigen::VectorXd& angle_ref_deg,
                            const CalibrationSettings& s) {
  const Eigen::Index n = t_s.size();
  if (sensor_v.size() != n || reference_v.size() != n || angle_ref_deg.size() != n)
    throw CalibrationError("calibration: the columns t_s, sensor_v, reference_v and angle_ref_deg differ in length");
  if (n < 10) throw CalibrationError("calibration: the recording has " + std::to_string(n) + " scans; far too few");

  CalibrationResult r;
  r.cal.reference_level_v = s.reference_level_v > 0 ? s.reference_level_v : reference_level(reference_v);
  if (!std::isfinite(r.cal.reference_level_v))
    throw CalibrationError("calibration: the reference channel has no positive sample (laser off?)");
  ReferenceGuard guard;
  guard.level_v = r.cal.reference_level_v;
  const Eigen::VectorXd v = normalise(sensor_v, reference_v, guard, &r.n_reference_rejected);

  r.segments = segment(t_s, angle_ref_deg, s.segmentation);

  // --- f5: quasi-static line from the settled part of each long hold (fig. 6).
  std::vector<double> hv, ha;
  for (const Segment& g : r.segments) {
    if (g.kind != Direction::kHold || g.duration_s() < s.min_hold_s) continue;
    const Eigen::Index b = g.begin + static_cast<Eigen::Index>(s.settle_fraction * static_cast<double>(g.size()));
    double sv = 0, sa = 0;
    int m = 0;
    for (Eigen::Index i = b; i < g.end; ++i)
      if (std::isfinite(v(i)) && std::isfinite(angle_ref_deg(i))) {
        sv += v(i);
        sa += angle_ref_deg(i);
        ++m;
      }
    if (m < 3) continue;
    hv.push_back(sv / m);
    ha.push_back(sa / m);
  }
  if (hv.size() < 3)
    throw CalibrationError("calibration: found " + std::to_string(hv.size()) + " hold(s) of at least " +
                           format_significant(s.min_hold_s, 3) + " s; the quasi-static fit (f5) needs at least 3 (protocol: 0-90 deg in 5 deg steps, 10 s holds)");
  r.quasi_static.hold_v = as_vec(hv);
  r.quasi_static.hold_angle_deg = as_vec(ha);
  r.quasi_static.angle_of_v = fit_line(r.quasi_static.hold_v, r.quasi_static.hold_angle_deg);
  r.quasi_static.v_of_angle = fit_line(r.quasi_static.hold_angle_deg, r.quasi_static.hold_v);
  if (r.quasi_static.angle_of_v.n == 0 || !(r.quasi_static.angle_of_v.slope < 0))
    throw CalibrationError("calibration: the hold voltages do not fall with the angle; the quasi-static line (f5) is not usable");
  ModelCoefficients& m = r.cal.model;
  m.c9 = -r.quasi_static.angle_of_v.slope;
  m.c10 = r.quasi_static.angle_of_v.intercept;
  const Eigen::VectorXd v_qs = (m.c10 - angle_ref_deg.array()) / m.c9;  // f5^-1 of the reference

  // --- Dynamic tests: long sweeps grouped by speed (table 1).
  std::vector<const Segment*> sweeps;
  for (const Segment& g : r.segments)
    if (g.kind != Direction::kHold && std::abs(g.amplitude_deg()) >= s.min_dynamic_sweep_deg &&
        std::abs(g.velocity_rad_s) > 0)
      sweeps.push_back(&g);
  std::sort(sweeps.begin(), sweeps.end(),
            [](const Segment* a, const Segment* b) { return std::abs(a->velocity_rad_s) < std::abs(b->velocity_rad_s); });
  std::vector<std::vector<const Segment*>> groups;
  for (const Segment* g : sweeps) {
    if (groups.empty() || std::abs(g->velocity_rad_s) > std::abs(groups.back().front()->velocity_rad_s) * (1 + s.velocity_tolerance))
      groups.emplace_back();
    groups.back().push_back(g);
  }

  double amin = std::numeric_limits<double>::infinity(), amax = -amin;
  struct Pool {
    std::vector<double> v, qs;
  };
  std::vector<std::array<Pool, 2>> pools;
  for (const auto& grp : groups) {
    VelocityTest vt;
    LineAccumulator acc[2];
    std::array<Pool, 2> pool;
    double wsum = 0;
    for (const Segment* g : grp) {
      const int k = g->kind == Direction::kFlexion ? 0 : 1;
      (k == 0 ? vt.n_flexion : vt.n_extension)++;
      wsum += std::abs(g->velocity_rad_s);
      append_finite(pool[static_cast<std::size_t>(k)].v, pool[static_cast<std::size_t>(k)].qs, v, v_qs, g->core_begin, g->core_end);
      for (Eigen::Index i = g->core_begin; i < g->core_end; ++i)
        if (std::isfinite(v(i)) && std::isfinite(angle_ref_deg(i))) {
          acc[k].add(angle_ref_deg(i), v(i));
          amin = std::min(amin, angle_ref_deg(i));
          amax = std::max(amax, angle_ref_deg(i));
        }
    }
    if (vt.n_flexion == 0 || vt.n_extension == 0) continue;  // a lone sweep: no loop to measure
    vt.velocity_rad_s = wsum / static_cast<double>(grp.size());
    vt.hysteresis = hysteresis_eq1(acc[0], acc[1]);
    vt.h_pct = std::abs(vt.hysteresis.pct);
    vt.f3_flexion = fit_line(as_vec(pool[0].v), as_vec(pool[0].qs));
    vt.f3_extension = fit_line(as_vec(pool[1].v), as_vec(pool[1].qs));
    vt.n_samples = static_cast<Eigen::Index>(pool[0].v.size() + pool[1].v.size());
    if (!vt.hysteresis.valid || vt.f3_flexion.n == 0 || vt.f3_extension.n == 0) continue;
    r.tests.push_back(vt);
    pools.push_back(std::move(pool));
  }
  if (r.tests.size() < 2)
    throw CalibrationError("calibration: found " + std::to_string(r.tests.size()) +
                           " velocity test(s) with both a flexion and an extension sweep of at least " +
                           format_significant(s.min_dynamic_sweep_deg, 3) + " deg; f1 and f2 need at least 2 velocities");

  // --- f1: h = c1 exp(c2 w).
  const auto nt = static_cast<Eigen::Index>(r.tests.size());
  Eigen::VectorXd w(nt), h(nt), af(nt), bf(nt), ae(nt), be(nt);
  for (Eigen::Index i = 0; i < nt; ++i) {
    const VelocityTest& vt = r.tests[static_cast<std::size_t>(i)];
    w(i) = vt.velocity_rad_s;
    h(i) = vt.h_pct;
    af(i) = vt.f3_flexion.slope;
    bf(i) = vt.f3_flexion.intercept;
    ae(i) = vt.f3_extension.slope;
    be(i) = vt.f3_extension.intercept;
  }
  try {
    r.f1 = fit_exponential(w, h);
  } catch (const std::invalid_argument& e) {
    throw CalibrationError(std::string("calibration: f1 (hysteresis against velocity): ") + e.what());
  }
  m.c1 = r.f1.c1;
  m.c2 = r.f1.c2;

  // --- f2 against the hysteresis f1 predicts at each test velocity.
  Eigen::VectorXd hf(nt);
  for (Eigen::Index i = 0; i < nt; ++i) hf(i) = r.f1(w(i));
  r.f2_a_flexion = fit_line(hf, af);
  r.f2_b_flexion = fit_line(hf, bf);
  r.f2_a_extension = fit_line(hf, ae);
  r.f2_b_extension = fit_line(hf, be);
  if (r.f2_a_flexion.n == 0 || r.f2_a_extension.n == 0)
    throw CalibrationError("calibration: f2 needs velocity tests with different hysteresis; all f1(w) are equal");
  m.flexion = {r.f2_a_flexion.slope, r.f2_a_flexion.intercept, r.f2_b_flexion.slope, r.f2_b_flexion.intercept, 1, 0};
  m.extension = {r.f2_a_extension.slope, r.f2_a_extension.intercept, r.f2_b_extension.slope, r.f2_b_extension.intercept, 1, 0};

  // --- f4: V_qs = c7 V1 - c8, all velocities of one direction pooled.
  for (int k = 0; k < 2; ++k) {
    std::vector<double> v1, qs;
    DirectionCoefficients& x = k == 0 ? m.flexion : m.extension;
    for (std::size_t g = 0; g < pools.size(); ++g) {
      const double hh = r.f1(r.tests[g].velocity_rad_s);
      const double a = x.c3 * hh + x.c4, b = x.c5 * hh + x.c6;
      const Pool& p = pools[g][static_cast<std::size_t>(k)];
      for (std::size_t i = 0; i < p.v.size(); ++i) {
        v1.push_back(a * p.v[i] + b);
        qs.push_back(p.qs[i]);
      }
    }
    LinearFit& f4 = k == 0 ? r.f4_flexion : r.f4_extension;
    f4 = fit_line(as_vec(v1), as_vec(qs));
    if (f4.n == 0) throw CalibrationError("calibration: f4 has no usable samples");
    x.c7 = f4.slope;
    x.c8 = -f4.intercept;
  }

  r.cal.angle_min_deg = amin;
  r.cal.angle_max_deg = amax;
  r.cal.velocity_min_rad_s = w.minCoeff();
  r.cal.velocity_max_rad_s = w.maxCoeff();
  r.eq11 = combined_equation(m, Direction::kFlexion);
  r.eq12 = combined_equation(m, Direction::kExtension);
  return r;
}

std::string format_combined_equation(const CombinedEquation& eq, Direction d) {
  const std::string e = "e^(" + format_significant(eq.c2, 4) + " w)";
  return std::string(d == Direction::kExtension ? "alpha_e" : "alpha_f") + " = (" + format_significant(eq.a1, 4) + " " + e +
         signed_term(eq.a0, 5) + ") Vmeas" + signed_term(eq.b1, 4) + " " + e + signed_term(eq.b0, 6);
}

}  // namespace pof::core
