#include "pof/core/dynamic_fit.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <tuple>
#include <utility>

#include <Eigen/Dense>

#include "pof/core/fit.hpp"
#include "pof/core/offline.hpp"

namespace pof::core {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The regression rows of one structure: the bend lag, operators, Prony states and speed filter run
// over the reference angle at the recording's rate; every `decim`-th usable scan becomes a row.
struct Design {
  MatrixXd X;
  VectorXd y;
  std::vector<Index> scan;  // scan index of each row
  int n_poly = 0, n_ops = 0, n_prony = 0;
};

Design build_design(const DynamicModel& st, const VectorXd& v, const VectorXd& ang, double rate_hz, int decim) {
  const Index n = v.size();
  Design d;
  d.n_poly = st.degree + 1;
  d.n_ops = st.n_operators;
  d.n_prony = st.n_prony;
  const Index p = d.n_poly + d.n_ops + d.n_prony;
  Index rows = 0;
  for (Index i = 0; i < n; i += decim) rows += std::isfinite(v(i)) && std::isfinite(ang(i));
  d.X.resize(rows, p);
  d.y.resize(rows);
  d.scan.reserve(static_cast<std::size_t>(rows));
  const DynamicKernel k(st, rate_hz);
  DynamicState s;
  BendLag lag(st.bend_lag_s, rate_hz);
  Index r = 0;
  for (Index i = 0; i < n; ++i) {
    if (!std::isfinite(ang(i))) continue;  // an unusable reference: the operators hold their state
    const double theta = lag.step(ang(i));
    if (i % decim == 0 && std::isfinite(v(i))) {
      const double delta = s.started ? theta - s.angle_deg : 0.0;
      const double x = (theta - st.angle_centre_deg) / st.angle_scale_deg;
      double xp = 1;
      for (int c = 0; c < d.n_poly; ++c, xp *= x) d.X(r, c) = xp;
      const double phi = st.rate_factor(k.speed_rad_s(s));
      for (int o = 0; o < d.n_ops; ++o) {
        const auto u = static_cast<std::size_t>(o);
        d.X(r, d.n_poly + o) = phi * std::clamp(s.stop[u] + delta, -st.threshold_deg[u], st.threshold_deg[u]);
      }
      for (int j = 0; j < d.n_prony; ++j) {
        const auto u = static_cast<std::size_t>(j);
        d.X(r, d.n_poly + d.n_ops + j) = s.prony[u] * k.decay[u] + k.ramp_gain[u] * delta;
      }
      d.y(r) = v(i);
      d.scan.push_back(i);
      ++r;
    }
    k.advance(s, theta);
  }
  return d;
}

struct Grams {
  std::vector<MatrixXd> G;
  std::vector<VectorXd> g;
  std::vector<double> yy;
  std::vector<Index> rows;
};

// One normal-equation block per held-out block (rows by their scan index).
Grams block_grams(const Design& d, const std::vector<Index>& fb, const std::vector<Index>& fe) {
  Grams gr;
  const Index p = d.X.cols();
  std::size_t row = 0;
  for (std::size_t b = 0; b < fb.size(); ++b) {
    while (row < d.scan.size() && d.scan[row] < fb[b]) ++row;
    const std::size_t r0 = row;
    while (row < d.scan.size() && d.scan[row] < fe[b]) ++row;
    const auto len = static_cast<Index>(row - r0);
    const auto Xb = d.X.middleRows(static_cast<Index>(r0), len);
    const auto yb = d.y.segment(static_cast<Index>(r0), len);
    MatrixXd G = MatrixXd::Zero(p, p);
    G.selfadjointView<Eigen::Lower>().rankUpdate(Xb.transpose());
    gr.G.emplace_back(G.selfadjointView<Eigen::Lower>());
    gr.g.emplace_back(Xb.transpose() * yb);
    gr.yy.push_back(yb.squaredNorm());
    gr.rows.push_back(len);
  }
  return gr;
}

double rss_of(double yy, const VectorXd& g, const MatrixXd& G, const VectorXd& b) {
  return std::max(0.0, yy - 2.0 * b.dot(g) + b.dot(G * b));
}

DynamicModel with_coefficients(DynamicModel m, const VectorXd& b, const Design& d) {
  for (int c = 0; c <= kMaxDegree; ++c) m.poly[static_cast<std::size_t>(c)] = c < d.n_poly ? b(c) : 0.0;
  for (int o = 0; o < d.n_ops; ++o) m.weight_v_per_deg[static_cast<std::size_t>(o)] = b(d.n_poly + o);
  for (int j = 0; j < d.n_prony; ++j) m.prony_gain_v_per_deg[static_cast<std::size_t>(j)] = b(d.n_poly + d.n_ops + j);
  return m;
}

// The angles the invertibility rule is checked at: the inverse's search bracket (the identified
// range plus a quarter of its span) on a grid of kRuleGrid + 1 points.
constexpr int kRuleGrid = 200;
double rule_angle(const DynamicModel& m, int g) {
  const double span = m.angle_max_deg - m.angle_min_deg;
  const double lo = m.angle_min_deg - 0.25 * span, hi = m.angle_max_deg + 0.25 * span;
  return lo + (hi - lo) * g / static_cast<double>(kRuleGrid);
}
double rule_phi_max(const DynamicModel& m) { return std::max(m.rate_factor(0), m.rate_factor(m.speed_limit_rad_s)); }
double centre_slope(const DynamicModel& m) { return m.quasi_static_slope(0.5 * (m.angle_min_deg + m.angle_max_deg)); }

// The inverse needs V(theta) strictly monotone over the search bracket for every state the
// operators can be in: the quasi-static slope must dominate the worst case of the operators
// whose weights oppose it (all elastic, phi at its largest) plus the Prony terms' instant slope.
bool invertible(const DynamicModel& m, double rate_hz) {
  if (*m.invalid_reason() != '\0') return false;
  const DynamicKernel k(m, rate_hz);
  const double c_slope = centre_slope(m);
  const double sign = c_slope < 0 ? -1.0 : 1.0;
  double ops = 0, prony = 0;
  for (int i = 0; i < m.n_operators; ++i) ops += sign * m.weight_v_per_deg[static_cast<std::size_t>(i)];
  for (int j = 0; j < m.n_prony; ++j)
    prony += sign * m.prony_gain_v_per_deg[static_cast<std::size_t>(j)] * k.ramp_gain[static_cast<std::size_t>(j)];
  const double worst_extra = std::min(0.0, rule_phi_max(m) * ops) + prony;
  for (int g = 0; g <= kRuleGrid; ++g)
    if (!(sign * m.quasi_static_slope(rule_angle(m, g)) + worst_extra > 0.2 * std::abs(c_slope))) return false;
  return true;
}

// The invertibility rule above at one angle theta, for operator weights that oppose the slope
// (the case that breaks it), as a linear function of the coefficients: row . b > 0 there.
VectorXd rule_row(const DynamicModel& st, const Design& d, double rate_hz, double theta, double sign) {
  const DynamicKernel k(st, rate_hz);
  VectorXd a = VectorXd::Zero(d.n_poly + d.n_ops + d.n_prony);
  const double x = (theta - st.angle_centre_deg) / st.angle_scale_deg;
  const double xc = (0.5 * (st.angle_min_deg + st.angle_max_deg) - st.angle_centre_deg) / st.angle_scale_deg;
  double xp = 1, xcp = 1;  // x^(c-1), xc^(c-1)
  for (int c = 1; c < d.n_poly; ++c, xp *= x, xcp *= xc) a(c) = sign * c * (xp - 0.2 * xcp) / st.angle_scale_deg;
  for (int o = 0; o < d.n_ops; ++o) a(d.n_poly + o) = sign * rule_phi_max(st);
  for (int j = 0; j < d.n_prony; ++j) a(d.n_poly + d.n_ops + j) = sign * k.ramp_gain[static_cast<std::size_t>(j)];
  return a;
}

// Least squares under the invertibility rule (docs/calibration.md, "The dynamic model", the
// constrained fit): min |y - X b|^2 with the operator weights of one sign and rule_row . b >= 0 at
// the angle where the unconstrained fit b0 breaks the rule worst, the angle of the smallest
// quasi-static slope (for a line, the rule is that one inequality). Its Lagrange multiplier mu is
// found by bisection: b(mu) = argmin |y - X b|^2 - 2 mu a.b pulls the operators' total weight in,
// and the line's slope out, until invertible() passes; the smallest such mu (to 1e-3) is kept.
// Empty when no mu gives an invertible fit (the candidate stays refused).
std::optional<VectorXd> solve_invertible(const MatrixXd& G, const VectorXd& g, const Design& d, const DynamicModel& st,
                                         double rate_hz, const VectorXd& b0) {
  const DynamicModel m0 = with_coefficients(st, b0, d);
  if (*m0.invalid_reason() != '\0') return std::nullopt;
  const double sign = centre_slope(m0) < 0 ? -1.0 : 1.0;
  int worst = 0;
  for (int gi = 1; gi <= kRuleGrid; ++gi)
    if (sign * m0.quasi_static_slope(rule_angle(m0, gi)) < sign * m0.quasi_static_slope(rule_angle(m0, worst))) worst = gi;
  const VectorXd a = rule_row(st, d, rate_hz, rule_angle(m0, worst), sign);
  const auto fit_at = [&](double mu) -> std::optional<VectorXd> {
    VectorXd b = one_signed_least_squares(G, g + mu * a, d.n_poly, d.n_ops);
    if (!invertible(with_coefficients(st, b, d), rate_hz)) return std::nullopt;
    return b;
  };
  // The multiplier's scale: the step mu G^-1 a that closes the violation of an unconstrained solve.
  const VectorXd ga = (G + 1e-10 * MatrixXd(G.diagonal().asDiagonal())).ldlt().solve(a);
  const double curvature = a.dot(ga), violation = -a.dot(b0);
  double hi = curvature > 0 && violation > 0 && std::isfinite(violation / curvature) ? violation / curvature : 1.0;
  double lo = 0;
  std::optional<VectorXd> best;
  for (int k = 0; k < 60 && !(best = fit_at(hi)); ++k) {
    lo = hi;
    hi *= 4;
  }
  if (!best) return std::nullopt;
  for (int k = 0; k < 40 && hi - lo > 1e-3 * hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    if (auto b = fit_at(mid)) {
      best = std::move(b);
      hi = mid;
    } else {
      lo = mid;
    }
  }
  return best;
}

// The coefficients of one structure: sign-constrained least squares, and with `constrained` set,
// a fit the inverse could not follow refitted under the invertibility rule (solve_invertible).
VectorXd solve_structure(const MatrixXd& G, const VectorXd& g, double yy, const Design& d, const DynamicModel& st,
                         double rate_hz, bool constrained, double* rss) {
  VectorXd b = one_signed_least_squares(G, g, d.n_poly, d.n_ops);
  if (constrained && !invertible(with_coefficients(st, b, d), rate_hz))
    if (std::optional<VectorXd> held = solve_invertible(G, g, d, st, rate_hz, b)) b = std::move(*held);
  if (rss != nullptr) *rss = rss_of(yy, g, G, b);
  return b;
}

struct Prepared {
  double rate_hz = 200;
  int decim = 1;
  double angle_min = 0, angle_max = 90, speed_max = 0.5;
  double sensitivity = 0;  // |dV/dtheta| of the least-squares line through the data [V/deg]
  std::vector<Index> fb, fe;
};

DynamicModel structure_of(const Prepared& pr, const DynamicFitSettings& s, int degree, int n_ops, int n_prony, double kappa,
                          double bend_lag) {
  DynamicModel m;
  m.bend_lag_s = bend_lag;
  m.lag_window_s = s.lag_window_s;
  m.degree = degree;
  m.angle_centre_deg = 0.5 * (pr.angle_min + pr.angle_max);
  m.angle_scale_deg = std::max(1.0, 0.5 * (pr.angle_max - pr.angle_min));
  m.angle_min_deg = pr.angle_min;
  m.angle_max_deg = pr.angle_max;
  const std::vector<double> r = operator_thresholds(n_ops, s.min_threshold_deg, s.max_threshold_fraction * (pr.angle_max - pr.angle_min));
  m.n_operators = n_ops;
  for (int i = 0; i < n_ops; ++i) m.threshold_deg[static_cast<std::size_t>(i)] = r[static_cast<std::size_t>(i)];
  const std::vector<double> tau = prony_time_constants(n_prony, s.min_tau_s, s.max_tau_s);
  m.n_prony = n_prony;
  for (int j = 0; j < n_prony; ++j) m.prony_tau_s[static_cast<std::size_t>(j)] = tau[static_cast<std::size_t>(j)];
  m.rate_gain_s_per_rad = kappa;
  m.speed_filter_s = s.speed_filter_s;
  m.speed_limit_rad_s = pr.speed_max;
  return m;
}

// One structure fitted with each block held out in turn: the per-block normal equations are built
// once, each fold solves (all blocks) - (its block). Empty blocks get no coefficients.
struct FoldFits {
  Design d;
  Grams gr;
  std::vector<VectorXd> beta;  // per block (empty for a block without rows)
  Index rows = 0;
};

FoldFits fit_folds(const DynamicModel& st, double rate_hz, int decim, const std::vector<Index>& fb,
                   const std::vector<Index>& fe, const VectorXd& v, const VectorXd& ang, bool constrained) {
  FoldFits ff;
  ff.d = build_design(st, v, ang, rate_hz, decim);
  ff.gr = block_grams(ff.d, fb, fe);
  const Index p = ff.d.X.cols();
  MatrixXd Gt = MatrixXd::Zero(p, p);
  VectorXd gt = VectorXd::Zero(p);
  double yt = 0;
  for (std::size_t b = 0; b < ff.gr.G.size(); ++b) {
    Gt += ff.gr.G[b];
    gt += ff.gr.g[b];
    yt += ff.gr.yy[b];
    ff.rows += ff.gr.rows[b];
  }
  for (std::size_t b = 0; b < ff.gr.G.size(); ++b)
    ff.beta.push_back(ff.gr.rows[b] == 0 ? VectorXd()
                                         : solve_structure(Gt - ff.gr.G[b], gt - ff.gr.g[b], yt - ff.gr.yy[b], ff.d, st,
                                                           rate_hz, constrained, nullptr));
  return ff;
}

// Blocked cross-validation of one structure, each fold fitted under the invertibility rule when
// `constrained` is set.
DynamicCandidate cross_validate(const DynamicModel& st, const Prepared& pr, const VectorXd& v, const VectorXd& ang,
                                double sensitivity, bool constrained) {
  DynamicCandidate c;
  c.constrained = constrained;
  c.degree = st.degree;
  c.n_operators = st.n_operators;
  c.n_prony = st.n_prony;
  c.rate_gain_s_per_rad = st.rate_gain_s_per_rad;
  c.bend_lag_s = st.bend_lag_s;
  const FoldFits ff = fit_folds(st, pr.rate_hz, pr.decim, pr.fb, pr.fe, v, ang, constrained);
  double held = 0;
  for (std::size_t b = 0; b < ff.beta.size(); ++b) {
    if (ff.beta[b].size() == 0) continue;
    if (!invertible(with_coefficients(st, ff.beta[b], ff.d), pr.rate_hz)) c.admissible = false;
    held += rss_of(ff.gr.yy[b], ff.gr.g[b], ff.gr.G[b], ff.beta[b]);
  }
  c.cv_rmse_v = ff.rows > 0 ? std::sqrt(held / static_cast<double>(ff.rows)) : kInf;
  c.cv_rmse_deg = c.cv_rmse_v / sensitivity;
  return c;
}

std::string fmt_g(double x) {
  char b[64];
  std::snprintf(b, sizeof b, "%g", x);
  return b;
}

// What the recording must hold: holds (the line and the relaxation) and both directions (the loop).
void require_protocol(const std::vector<Segment>& seg, const DynamicFitSettings& s) {
  int holds = 0, flex = 0, ext = 0;
  for (const Segment& g : seg) {
    if (g.kind == Direction::kHold && g.duration_s() >= s.min_hold_s) ++holds;
    if (g.kind == Direction::kFlexion && std::abs(g.amplitude_deg()) >= 5) ++flex;
    if (g.kind == Direction::kExtension && std::abs(g.amplitude_deg()) >= 5) ++ext;
  }
  if (holds < 3)
    throw DynamicFitError("dynamic fit: found " + std::to_string(holds) + " hold(s) of at least " + fmt_g(s.min_hold_s) +
                          " s; the quasi-static line and the relaxation need at least 3 (the paper's quasi-static steps)");
  if (flex == 0 || ext == 0)
    throw DynamicFitError("dynamic fit: found " + std::to_string(flex) + " flexion and " + std::to_string(ext) +
                          " extension movement(s) of at least 5 deg; the hysteresis loop needs both directions");
}

// The reference angle's range over the usable scans (into pr), and the quasi-static sensitivity:
// |dV/dtheta| of the least-squares line through them.
double range_and_sensitivity(Prepared& pr, const VectorXd& v, const VectorXd& ang) {
  LineAccumulator line;
  pr.angle_min = kInf;
  pr.angle_max = -kInf;
  for (Index i = 0; i < v.size(); ++i)
    if (std::isfinite(v(i)) && std::isfinite(ang(i))) {
      line.add(ang(i), v(i));
      pr.angle_min = std::min(pr.angle_min, ang(i));
      pr.angle_max = std::max(pr.angle_max, ang(i));
    }
  if (!line.ok() || !(pr.angle_max - pr.angle_min > 5))
    throw DynamicFitError("dynamic fit: the reference angle spans less than 5 deg");
  const double sensitivity = std::abs(line.slope());
  if (!(sensitivity > 0)) throw DynamicFitError("dynamic fit: the sensor voltage does not change with the angle");
  return sensitivity;
}

// The recording as the search reads it: rate and decimation, range, speed, sensitivity and the
// held-out blocks. Throws DynamicFitError saying what the recording lacks.
Prepared prepare(const VectorXd& t, const VectorXd& v, const VectorXd& ang, const DynamicFitSettings& s) {
  const Index n = t.size();
  if (v.size() != n || ang.size() != n) throw DynamicFitError("dynamic fit: the columns differ in length");
  Prepared pr;
  pr.rate_hz = median_rate_hz(t);
  if (!(pr.rate_hz > 0)) throw DynamicFitError("dynamic fit: the time column does not increase");
  pr.decim = std::max(1, static_cast<int>(std::lround(pr.rate_hz / s.fit_rate_hz)));
  const std::vector<Segment> seg = segment(t, ang, s.segmentation);
  require_protocol(seg, s);
  pr.sensitivity = range_and_sensitivity(pr, v, ang);
  double vmax = 0;
  for (const Segment& g : seg) vmax = std::max(vmax, std::abs(g.velocity_rad_s));
  pr.speed_max = std::max(0.05, vmax);
  hold_blocks(seg, n, s.folds, pr.fb, pr.fe);
  return pr;
}

bool same_structure(const DynamicCandidate& x, const DynamicCandidate& y) {
  return x.degree == y.degree && x.n_operators == y.n_operators && x.n_prony == y.n_prony &&
         x.rate_gain_s_per_rad == y.rate_gain_s_per_rad && x.bend_lag_s == y.bend_lag_s && x.constrained == y.constrained;
}

// The structures cross-validated so far (fit_dynamic's result lists them, in the order tried),
// each scored once; `constrained`: this search fits under the invertibility rule and reads only
// its own candidates.
class Scored {
 public:
  Scored(std::vector<DynamicCandidate>& all, const Prepared& pr, const DynamicFitSettings& s, const VectorXd& v,
         const VectorXd& ang, bool constrained)
      : all_(all), pr_(pr), s_(s), v_(v), ang_(ang), constrained_(constrained) {}

  // The rate gain scales the operators only (phi(w) S_i): with none it is no structure of its own,
  // so it is scored once, at 0, and never wins a tie at a grid edge.
  void try_structure(int deg, int ops, int k, double kappa, double lag = 0.0) {
    if (ops == 0) kappa = 0.0;
    const DynamicCandidate key{.degree = deg, .n_operators = ops, .n_prony = k, .rate_gain_s_per_rad = kappa, .bend_lag_s = lag,
                               .constrained = constrained_};
    for (const DynamicCandidate& c : all_)  // each structure is scored once
      if (same_structure(c, key)) return;
    all_.push_back(cross_validate(structure_of(pr_, s_, deg, ops, k, kappa, lag), pr_, v_, ang_, pr_.sensitivity, constrained_));
  }

  // The admissible structure of lowest held-out error so far (nullptr: none). It points into the
  // list, which every try_structure may grow: read it again after each batch.
  [[nodiscard]] const DynamicCandidate* best() const {
    const DynamicCandidate* b = nullptr;
    for (const DynamicCandidate& c : all_)
      if (c.constrained == constrained_ && c.admissible && std::isfinite(c.cv_rmse_v) && (b == nullptr || c.cv_rmse_v < b->cv_rmse_v))
        b = &c;
    return b;
  }

 private:
  std::vector<DynamicCandidate>& all_;
  const Prepared& pr_;
  const DynamicFitSettings& s_;
  const VectorXd& v_;
  const VectorXd& ang_;
  bool constrained_;
};

// The polynomial's degree: each degree with a middle structure, and alone (the polynomial alone
// is invertible whenever it is monotone).
int choose_degree(Scored& sc, const DynamicFitSettings& s) {
  const int mid_ops = s.operator_counts[s.operator_counts.size() / 2];
  const int mid_k = s.prony_counts[s.prony_counts.size() / 2];
  for (int deg : s.degrees) {
    sc.try_structure(deg, mid_ops, mid_k, 0.0);
    sc.try_structure(deg, 0, 0, 0.0);
  }
  const DynamicCandidate* b = sc.best();
  if (b == nullptr) throw DynamicFitError("dynamic fit: no quasi-static polynomial gives an invertible model on this recording");
  return b->degree;
}

// The operator x Prony counts at the rate gain and lag of `start`.
void try_counts(Scored& sc, const DynamicFitSettings& s, int deg, const DynamicCandidate& start) {
  for (int ops : s.operator_counts)
    for (int k : s.prony_counts) sc.try_structure(deg, ops, k, start.rate_gain_s_per_rad, start.bend_lag_s);
  // Without operators the structure has no rate gain to offer them (it is pinned to 0), and
  // operators may be invertible only with one (a loop that narrows or widens with speed): the
  // operator counts are then also tried at every rate gain (at its Prony count and lag); the
  // next round, if any is left, settles the rest.
  if (start.n_operators == 0)
    for (double kp : s.rate_gains_s_per_rad)
      for (int ops : s.operator_counts) sc.try_structure(deg, ops, start.n_prony, kp, start.bend_lag_s);
}

// The bend lag jointly with the rate gain (both widen the loop with speed) at the best counts.
void try_gains_and_lags(Scored& sc, const DynamicFitSettings& s, int deg) {
  const DynamicCandidate counts = *sc.best();
  for (double kp : s.rate_gains_s_per_rad) {
    sc.try_structure(deg, counts.n_operators, counts.n_prony, kp, 0.0);
    for (double lag : s.bend_lags_s) sc.try_structure(deg, counts.n_operators, counts.n_prony, kp, lag);
  }
}

// Around the best lag, if any, at about a quarter of the grid's doubling, then at half that step.
void refine_lag(Scored& sc, const DynamicFitSettings& s, int deg) {
  if (!(sc.best()->bend_lag_s > 0)) return;
  const DynamicCandidate g = *sc.best();
  for (double f : {0.71, 0.84, 1.19, 1.41})
    for (double kp : s.rate_gains_s_per_rad) sc.try_structure(deg, g.n_operators, g.n_prony, kp, g.bend_lag_s * f);
  const DynamicCandidate h = *sc.best();
  for (double f : {0.92, 1.09}) sc.try_structure(deg, h.n_operators, h.n_prony, h.rate_gain_s_per_rad, h.bend_lag_s * f);
}

// The structure chosen: the polynomial's degree with a middle structure, then coordinate descent
// over the rest to a fixed point: the operator x Prony counts at the current rate gain and lag,
// then the bend lag jointly with the rate gain at the current counts, refined to ~5 % around the
// best; again until a round leaves the best structure unchanged (at most max_search_rounds;
// docs/calibration.md, "The dynamic model"). One pass is not enough: a large lag makes every
// structure with operators non-invertible at tau_b = 0 (the narrowest operator takes the lag's
// loop), so counts chosen before the lag is found are wrong.
DynamicCandidate search_structure(Scored& sc, const DynamicFitSettings& s) {
  const int deg = choose_degree(sc, s);
  const DynamicCandidate* b = sc.best();
  for (int round = 0; round < s.max_search_rounds; ++round) {
    const DynamicCandidate start = *b;
    try_counts(sc, s, deg, start);
    try_gains_and_lags(sc, s, deg);
    refine_lag(sc, s, deg);
    b = sc.best();
    if (same_structure(*b, start)) break;
  }
  return *b;
}

// The structure of c fitted on every scan (under the invertibility rule if c was scored so), its
// residual sum of squares and number of rows.
DynamicModel fit_whole(const DynamicCandidate& c, const Prepared& pr, const DynamicFitSettings& s, const VectorXd& v,
                       const VectorXd& ang, double& rss, Index& rows) {
  const DynamicModel st = structure_of(pr, s, c.degree, c.n_operators, c.n_prony, c.rate_gain_s_per_rad, c.bend_lag_s);
  const Design d = build_design(st, v, ang, pr.rate_hz, pr.decim);
  const MatrixXd G = d.X.transpose() * d.X;
  const VectorXd g = d.X.transpose() * d.y;
  rows = d.y.size();
  return with_coefficients(st, solve_structure(G, g, d.y.squaredNorm(), d, st, pr.rate_hz, c.constrained, &rss), d);
}

// The chosen structure refitted on every scan (res.model) and its training error. Throws when
// the fit is not invertible.
void fit_chosen(DynamicFitResult& res, const Prepared& pr, const DynamicFitSettings& s, const VectorXd& v, const VectorXd& ang) {
  double rss = 0;
  Index rows = 0;
  res.model = fit_whole(res.chosen, pr, s, v, ang, rss, rows);
  if (!invertible(res.model, pr.rate_hz))
    throw DynamicFitError("dynamic fit: the fitted model is not invertible over the angle range (the hysteresis or relaxation terms outweigh the quasi-static slope)");
  res.n_used = rows;
  res.train_rmse_v = std::sqrt(rss / static_cast<double>(std::max<Index>(1, rows)));
  res.train_rmse_deg = res.train_rmse_v / pr.sensitivity;
}

// How far the output of m runs backwards at rest after a reversal from a saturated branch
// (docs/calibration.md, "The dynamic model"): operator i stays elastic for 2 r_i of travel, so
// the branch's slope at travel t is q'(centre) + phi_max sum_{2 r_i > t} c_i, piecewise constant
// and back to q's sign once the operators that outweigh it have slipped. Returns the travel where
// it is back (0: it never runs backwards) and the travel where the output is back at its value at
// the reversal, past which one voltage no longer stands for two angles.
std::pair<double, double> backwards_run(const DynamicModel& m) {
  const double slope = centre_slope(m), sign = slope < 0 ? -1.0 : 1.0;
  double t0 = 0, f = 0, back = 0;  // f: the output's change since the reversal, in q's sense of travel
  for (int k = 0; k <= m.n_operators; ++k) {
    double sk = sign * slope;
    for (int i = k; i < m.n_operators; ++i) sk += rule_phi_max(m) * sign * m.weight_v_per_deg[static_cast<std::size_t>(i)];
    if (k < m.n_operators) {
      const double t1 = 2 * m.threshold_deg[static_cast<std::size_t>(k)];
      if (sk < 0) back = t1;
      f += sk * (t1 - t0);
      t0 = t1;
      if (back > 0 && f >= 0 && sk > 0) return {back, t1 - f / sk};  // back at the reversal's value within this piece
    } else if (back > 0) {
      return {back, t0 - f / sk};  // the line alone (sk = |q'| > 0) brings it back
    }
  }
  return {0.0, 0.0};
}

// When refusing the fits the inverse could not follow leaves the best admissible structure much
// worse than the best refused one, the sensor itself may run backwards after a reversal (a loop
// whose elastic slope outweighs the line's): rather than drop the operators, the search runs
// again with every fit held to the invertibility rule, and the best refused structure, fitted
// without it, says how far the output runs backwards (docs/calibration.md, "The dynamic model").
void constrain_if_collapsed(DynamicFitResult& res, const Prepared& pr, const DynamicFitSettings& s, const VectorXd& v,
                            const VectorXd& ang) {
  const DynamicCandidate* refused = nullptr;
  for (const DynamicCandidate& c : res.candidates)
    if (!c.admissible && std::isfinite(c.cv_rmse_v) && (refused == nullptr || c.cv_rmse_v < refused->cv_rmse_v)) refused = &c;
  if (refused == nullptr || !(res.chosen.cv_rmse_v > s.constrain_above_ratio * refused->cv_rmse_v)) return;
  res.unconstrained = *refused;  // a copy: the search below grows the list
  Scored constrained(res.candidates, pr, s, v, ang, true);
  const DynamicCandidate best = search_structure(constrained, s);
  if (best.cv_rmse_v < res.chosen.cv_rmse_v) res.chosen = best;
  double rss = 0;
  Index rows = 0;
  std::tie(res.backwards_deg, res.backwards_ambiguity_deg) = backwards_run(fit_whole(*res.unconstrained, pr, s, v, ang, rss, rows));
}

}  // namespace

std::vector<double> operator_thresholds(
int n, double min_deg, double max_deg) {
  std::vector<double> r;
  max_deg = std::max(max_deg, min_deg);
  for (int i = 0; i < n; ++i)
    r.push_back(n == 1 ? std::sqrt(min_deg * max_deg) : min_deg * std::pow(max_deg / min_deg, static_cast<double>(i) / (n - 1)));
  return r;
}

std::vector<double> prony_time_constants(int k, double min_s, double max_s) {
  // k points at the centres of k equal log-intervals of [min_s, max_s]: 1 term -> the geometric mean.
  std::vector<double> tau;
  for (int j = 0; j < k; ++j) tau.push_back(min_s * std::pow(max_s / min_s, (j + 0.5) / k));
  return tau;
}

void hold_blocks(const std::vector<Segment>& segments, Index n, int folds, std::vector<Index>& begin, std::vector<Index>& end) {
  std::vector<char> hold(static_cast<std::size_t>(n), 0);
  for (const Segment& g : segments)
    if (g.kind == Direction::kHold)
      for (Index i = g.begin; i < g.end; ++i) hold[static_cast<std::size_t>(i)] = 1;
  const auto nf = static_cast<Index>(std::max(2, folds));
  std::vector<Index> cut{0};
  for (Index f = 1; f < nf; ++f) {
    const Index target = f * n / nf, reach = n / (2 * nf);
    Index best = target;
    for (Index d = 0; d <= reach; ++d) {
      if (target + d < n && hold[static_cast<std::size_t>(target + d)]) { best = target + d; break; }
      if (target - d >= 0 && hold[static_cast<std::size_t>(target - d)]) { best = target - d; break; }
    }
    if (best > cut.back() + 10) cut.push_back(best);
  }
  cut.push_back(n);
  begin.clear();
  end.clear();
  for (std::size_t i = 0; i + 1 < cut.size(); ++i) {
    begin.push_back(cut[i]);
    end.push_back(cut[i + 1]);
  }
}

// The recording checked and prepared, the structure searched by blocked cross-validation, and
// the chosen one refitted on every scan (docs/calibration.md, "The dynamic model").
DynamicFitResult fit_dynamic(const VectorXd& t, const VectorXd& v, const VectorXd& ang, const DynamicFitSettings& s) {
  const Prepared pr = prepare(t, v, ang, s);
  DynamicFitResult res;
  res.sensitivity_v_per_deg = pr.sensitivity;
  res.fold_begin = pr.fb;
  res.fold_end = pr.fe;
  Scored scored(res.candidates, pr, s, v, ang, false);
  res.chosen = search_structure(scored, s);
  constrain_if_collapsed(res, pr, s, v, ang);
  fit_chosen(res, pr, s, v, ang);
  try {
    res.estimator = identify_estimator_noise(t, v, ang, s.estimator);
  } catch (const std::runtime_error& e) {
    res.estimator_note = e.what();
  }
  return res;
}

std::vector<std::optional<DynamicModel>> fold_models(
const DynamicFitResult& fit, const VectorXd& t, const VectorXd& v,
                                                     const VectorXd& ang, const DynamicFitSettings& s) {
  const double rate = median_rate_hz(t);
  if (!(rate > 0)) throw DynamicFitError("dynamic fit: the time column does not increase");
  const int decim = std::max(1, static_cast<int>(std::lround(rate / s.fit_rate_hz)));
  const FoldFits ff = fit_folds(fit.model, rate, decim, fit.fold_begin, fit.fold_end, v, ang, fit.chosen.constrained);
  std::vector<std::optional<DynamicModel>> out;
  for (const VectorXd& beta : ff.beta) {
    std::optional<DynamicModel> m;
    if (beta.size() > 0) m = with_coefficients(fit.model, beta, ff.d);
    if (m && !invertible(*m, rate)) m.reset();
    out.push_back(m);
  }
  return out;
}

VectorXd dynamic_coefficients(const DynamicModel& m) {
  VectorXd b(m.degree + 1 + m.n_operators + m.n_prony);
  Index c = 0;
  for (int k = 0; k <= m.degree; ++k) b(c++) = m.poly[static_cast<std::size_t>(k)];
  for (int o = 0; o < m.n_operators; ++o) b(c++) = m.weight_v_per_deg[static_cast<std::size_t>(o)];
  for (int j = 0; j < m.n_prony; ++j) b(c++) = m.prony_gain_v_per_deg[static_cast<std::size_t>(j)];
  return b;
}

DynamicModel with_dynamic_coefficients(DynamicModel m, const VectorXd& b) {
  Design d;
  d.n_poly = m.degree + 1;
  d.n_ops = m.n_operators;
  d.n_prony = m.n_prony;
  return with_coefficients(m, b, d);
}

MatrixXd dynamic_regressors(const DynamicModel& m, const VectorXd& angle, double rate_hz) {
  Design d = build_design(m, VectorXd::Zero(angle.size()), angle, rate_hz, 1);
  if (d.X.rows() == angle.size()) return std::move(d.X);  // every reference usable: one row per scan
  MatrixXd out = MatrixXd::Zero(angle.size(), d.X.cols());
  for (std::size_t r = 0; r < d.scan.size(); ++r) out.row(d.scan[r]) = d.X.row(static_cast<Index>(r));
  return out;
}

bool dynamic_invertible(const DynamicModel& m, double rate_hz) { return invertible(m, rate_hz); }

VectorXd forward_dynamic(const DynamicModel& m, const VectorXd& angle, double rate_hz) {
  const DynamicKernel k(m, rate_hz);
  DynamicState s;
  BendLag lag(m.bend_lag_s, rate_hz);
  VectorXd out(angle.size());
  double last = std::nan("");
  for (Index i = 0; i < angle.size(); ++i) {
    if (std::isfinite(angle(i))) last = angle(i);
    out(i) = std::isfinite(last) ? k.forward(s, lag.step(last)) : std::nan("");
  }
  return out;
}

}  // namespace pof::core
