// The gap workflow (docs/gap.md): baseline fit, candidate effects, time-blocked cross-validation,
// acceptance rule, iteration. Method and rule: docs/gap.md.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <future>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <string>

#include <Eigen/Dense>
#include <unsupported/Eigen/FFT>

#include "pof/gap/gap.hpp"
#include "pof/gap/localise.hpp"
#include "pof/gap/signals.hpp"
#include "pof/base/errors.hpp"

namespace pof::gap {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using nlohmann::json;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- time blocks ---------------------------------------------------------------------------------
struct Blocks {
  std::vector<Index> start, len;
  [[nodiscard]] std::size_t size() const { return start.size(); }
};

// K contiguous blocks. Each boundary is moved to the nearest hold scan so no movement (and so no
// cycle) is cut in two: the folds are time blocks of whole cycles, never random samples (docs/gap.md).
Blocks make_blocks(const Kinematics& k, int folds) {
  const Index n = k.w.size();
  const auto nf = static_cast<Index>(folds);
  std::vector<Index> cut{0};
  for (Index f = 1; f < nf; ++f) {
    const Index target = f * n / nf;
    const Index reach = n / (2 * nf);
    Index best = target;
    for (Index d = 0; d <= reach; ++d) {
      if (target + d < n && k.s_move(target + d) == 0) { best = target + d; break; }
      if (target - d >= 0 && k.s_move(target - d) == 0) { best = target - d; break; }
    }
    if (best > cut.back() + 10) cut.push_back(best);
  }
  cut.push_back(n);
  Blocks b;
  for (std::size_t i = 0; i + 1 < cut.size(); ++i) {
    b.start.push_back(cut[i]);
    b.len.push_back(cut[i + 1] - cut[i]);
  }
  return b;
}

// ---- least squares on per-block normal equations -------------------------------------------------
struct Grams {
  std::vector<MatrixXd> G;
  std::vector<VectorXd> g;
  std::vector<double> yy;
};

Grams make_grams(const MatrixXd& X, const VectorXd& y, const Blocks& b) {
  Grams gr;
  for (std::size_t i = 0; i < b.size(); ++i) {
    const auto Xb = X.middleRows(b.start[i], b.len[i]);
    const auto yb = y.segment(b.start[i], b.len[i]);
    MatrixXd G = MatrixXd::Zero(X.cols(), X.cols());
    G.selfadjointView<Eigen::Lower>().rankUpdate(Xb.transpose());
    gr.G.push_back(G.selfadjointView<Eigen::Lower>());
    gr.g.push_back(Xb.transpose() * yb);
    gr.yy.push_back(yb.squaredNorm());
  }
  return gr;
}

// Base grams extended by new columns C (only the new cross products are computed).
Grams extend_grams(const Grams& base, const MatrixXd& X0, const MatrixXd& C, const VectorXd& y, const Blocks& b) {
  Grams gr;
  const Index k0 = X0.cols(), c = C.cols();
  for (std::size_t i = 0; i < b.size(); ++i) {
    const auto X0b = X0.middleRows(b.start[i], b.len[i]);
    const auto Cb = C.middleRows(b.start[i], b.len[i]);
    const auto yb = y.segment(b.start[i], b.len[i]);
    MatrixXd G(k0 + c, k0 + c);
    G.topLeftCorner(k0, k0) = base.G[i];
    G.topRightCorner(k0, c) = X0b.transpose() * Cb;
    G.bottomLeftCorner(c, k0) = G.topRightCorner(k0, c).transpose();
    G.bottomRightCorner(c, c) = Cb.transpose() * Cb;
    VectorXd g(k0 + c);
    g.head(k0) = base.g[i];
    g.tail(c) = Cb.transpose() * yb;
    gr.G.push_back(std::move(G));
    gr.g.push_back(std::move(g));
    gr.yy.push_back(base.yy[i]);
  }
  return gr;
}

// Jacobi-scaled LDLT with a tiny ridge: a column that is all zeros (an input that never varies)
// gets a zero coefficient instead of a NaN.
VectorXd solve(const MatrixXd& G, const VectorXd& g) {
  const Index k = G.rows();
  VectorXd d(k);
  for (Index i = 0; i < k; ++i) d(i) = G(i, i) > 1e-300 ? 1.0 / std::sqrt(G(i, i)) : 0.0;
  MatrixXd Gs = d.asDiagonal() * G * d.asDiagonal();
  Gs.diagonal().array() += 1e-10;
  const VectorXd bs = Gs.ldlt().solve(d.asDiagonal() * g);
  return d.asDiagonal() * bs;
}

double rss_of(double yy, const VectorXd& g, const MatrixXd& G, const VectorXd& beta) {
  return std::max(0.0, yy - 2.0 * beta.dot(g) + beta.dot(G * beta));
}

struct FoldFit {
  std::vector<std::size_t> theta_idx;  // per fold: grid index chosen on the training blocks
  std::vector<VectorXd> beta;          // per fold
  std::vector<double> heldout_rss;     // per fold
  double cv_rss = 0;                   // sum of held-out RSS
  std::size_t full_idx = 0;            // grid index minimising the all-data RSS
  VectorXd beta_full;
  double full_rss = 0;
};

// Strict blocked CV over a grid of nonlinear parameters: for each fold, the grid value and the
// linear coefficients are chosen on the training blocks only; the held-out block only scores.
FoldFit cross_validate(const std::vector<Grams>& per_theta) {
  FoldFit ff;
  const std::size_t nb = per_theta.front().G.size();
  std::vector<MatrixXd> Gt(per_theta.size());
  std::vector<VectorXd> gt(per_theta.size());
  std::vector<double> yt(per_theta.size());
  for (std::size_t t = 0; t < per_theta.size(); ++t) {
    Gt[t] = per_theta[t].G[0];
    gt[t] = per_theta[t].g[0];
    yt[t] = per_theta[t].yy[0];
    for (std::size_t b = 1; b < nb; ++b) {
      Gt[t] += per_theta[t].G[b];
      gt[t] += per_theta[t].g[b];
      yt[t] += per_theta[t].yy[b];
    }
  }
  ff.full_rss = kInf;
  for (std::size_t t = 0; t < per_theta.size(); ++t) {
    const VectorXd beta = solve(Gt[t], gt[t]);
    const double r = rss_of(yt[t], gt[t], Gt[t], beta);
    if (r < ff.full_rss) { ff.full_rss = r; ff.full_idx = t; ff.beta_full = beta; }
  }
  for (std::size_t f = 0; f < nb; ++f) {
    double best = kInf;
    std::size_t bi = 0;
    VectorXd bb;
    for (std::size_t t = 0; t < per_theta.size(); ++t) {
      const MatrixXd G = Gt[t] - per_theta[t].G[f];
      const VectorXd g = gt[t] - per_theta[t].g[f];
      const double yy = yt[t] - per_theta[t].yy[f];
      const VectorXd beta = solve(G, g);
      const double r = rss_of(yy, g, G, beta);
      if (r < best) { best = r; bi = t; bb = beta; }
    }
    const double h = rss_of(per_theta[bi].yy[f], per_theta[bi].g[f], per_theta[bi].G[f], bb);
    ff.theta_idx.push_back(bi);
    ff.beta.push_back(bb);
    ff.heldout_rss.push_back(h);
    ff.cv_rss += h;
  }
  return ff;
}

// ---- model state and the candidate terms ---------------------------------------------------------
struct Term {
  std::string effect;
  double theta = 0;  // the nonlinear parameter (tau, frequency); unused for linear terms
};

struct State {
  double delay_s = 0;
  double backlash_deg = 0;
  std::vector<Term> terms;
};

struct Context {
  const Signals* s = nullptr;
  core::ModelCoefficients m;
  double p0 = 0;  // 1/c9 of the paper: V per deg, scales angle-like terms into volts
  Blocks blocks;
  double duration_s = 0;
};

// Columns of one effect (volts per unit of its linear parameters). Physical forms in docs/gap.md.
MatrixXd effect_columns(const std::string& e, double theta, const Context& cx, const Kinematics& k) {
  const Signals& s = *cx.s;
  const Index n = s.n;
  const double p0 = cx.p0;
  if (e == "static_nonlinearity") {
    // Angle error [deg] = k2 u^2 + k3 u^3 + k4 u^4 + k5 u^5, u = (angle - 45)/45: a bow, an S, and
    // the +-2 % S-shaped linearity error of a precision potentiometer (sin(2 pi angle/90) needs u^5).
    MatrixXd C(n, 4);
    const VectorXd u = (k.angle.array() - 45.0) / 45.0;
    C.col(0) = -p0 * u.array().square();
    C.col(1) = -p0 * u.array().cube();
    C.col(2) = -p0 * u.array().square().square();
    C.col(3) = -p0 * u.array().square().square() * u.array();
    return C;
  }
  if (e == "drift") {
    // Linear in time: a quadratic term extrapolates badly into the first and last held-out blocks
    // and starts to mimic any slow wander (e.g. of the light source).
    MatrixXd C(n, 1);  // angle error [deg] = d1 tau, tau = t/T - 1/2
    C.col(0) = -p0 * (s.t.array() / cx.duration_s - 0.5).matrix();
    return C;
  }
  if (e == "creep") {
    // Standard-linear-solid memory: the fibre sees angle + g (x - angle), x the angle low-passed
    // with time constant tau, so after a step the output relaxes with tau (viscoelasticity).
    MatrixXd C(n, 1);
    const double a = 1.0 - std::exp(-s.dt / theta);
    double x = k.angle(0);
    for (Index i = 0; i < n; ++i) {
      x += a * (k.angle(i) - x);
      C(i, 0) = -p0 * (x - k.angle(i));
    }
    return C;
  }
  if (e == "rate_dependent_hysteresis") {
    // Hysteresis beyond the paper's f1-f4: a direction-signed opening that grows with the speed,
    // +-A (1 - exp(-w/w0)) sin(pi angle/90) (largest mid-range, as viscoelastic hysteresis is;
    // paper sect. 2.2), w0 = theta, with no memory (it vanishes the moment the knee stops, unlike
    // creep); plus a rescaling of the paper's own hysteresis offset (coefficient = scale - 1).
    MatrixXd C(n, 2);
    for (Index i = 0; i < n; ++i)
      C(i, 0) = k.s_move(i) * (1.0 - std::exp(-std::abs(k.w(i)) / theta)) * std::sin(std::numbers::pi * k.angle(i) / 90.0);
    C.col(1) = k.hyst_v;
    return C;
  }
  if (e == "acceleration_dependence") {
    // The acceleration of the reference angle, differentiated twice over +-theta: a short window
    // follows the drive's acceleration steps, a long one keeps potentiometer noise out of the
    // prediction; the window is a nonlinear parameter chosen on the training blocks.
    const auto h = std::max<Index>(1, static_cast<Index>(std::lround(theta / s.dt)));
    const VectorXd w = local_slope(k.angle, s.dt, h) * (std::numbers::pi / 180.0);
    MatrixXd C(n, 1);
    C.col(0) = -p0 * local_slope(w, s.dt, h);
    return C;
  }
  if (e == "source_power_coupling") {
    // Imperfect cancellation: v ~ T(angle) (1 + gamma dP/P) + kappa dP/P (different photodiode
    // responses / offsets), dP/P seen by the reference fibre.
    MatrixXd C(n, 2);
    const VectorXd vq = k.offset + k.col_p * p0 + k.col_q * (cx.m.c10 * p0);
    C.col(0) = vq.cwiseProduct(s.ref_rel);
    C.col(1) = s.ref_rel;
    return C;
  }
  if (e == "periodic_interference") {
    // A sinusoid at frequency theta (mains, vibration) picked up on the sensor channel, plus the
    // same pick-up on the reference channel, which the normalisation v = sensor L / reference turns
    // into -v dR/L: an amplitude proportional to the level v (hence the v-weighted pair).
    MatrixXd C(n, 4);
    const double om = 2.0 * std::numbers::pi * theta;
    for (Index i = 0; i < n; ++i) {
      const double vq = k.offset(i) + k.col_p(i) * p0 + k.col_q(i) * (cx.m.c10 * p0);
      C(i, 0) = std::sin(om * s.t(i));
      C(i, 1) = std::cos(om * s.t(i));
      C(i, 2) = vq * C(i, 0);
      C(i, 3) = vq * C(i, 1);
    }
    return C;
  }
  return MatrixXd(n, 0);  // time_delay and backlash live in the kinematics (signals.cpp)
}

constexpr Index kBaseCols = 3;  // p' = 1/c9, q' = c10/c9, kappa (reference-level scale)

struct Design {
  Kinematics k;
  MatrixXd X;
  VectorXd y;
};

Design build_design(const Context& cx, const State& st) {
  Design d;
  d.k = make_kinematics(cx.s->angle, cx.s->dt, st.delay_s, cx.m);
  if (st.backlash_deg > 0) apply_backlash(d.k, st.backlash_deg, cx.s->dt, cx.m);
  std::vector<MatrixXd> cols;
  Index total = kBaseCols;
  for (const Term& t : st.terms) {
    cols.push_back(effect_columns(t.effect, t.theta, cx, d.k));
    total += cols.back().cols();
  }
  // Baseline: v = kappa * offset + p' col_p + q' col_q. kappa absorbs the unknown reference level
  // at calibration (v is normalised by the recording's median reference, not the calibration one):
  // v_norm = v_model / g is linear in (p/g, q/g, 1/g), so the refit stays linear least squares.
  d.X.resize(cx.s->n, total);
  d.X.col(0) = d.k.col_p;
  d.X.col(1) = d.k.col_q;
  d.X.col(2) = d.k.offset;
  Index c = kBaseCols;
  for (const MatrixXd& C : cols) {
    d.X.middleCols(c, C.cols()) = C;
    c += C.cols();
  }
  d.y = cx.s->v;
  return d;
}

int linear_count(const std::string& e) {
  if (e == "periodic_interference" || e == "static_nonlinearity") return 4;
  if (e == "source_power_coupling" || e == "rate_dependent_hysteresis") return 2;
  if (e == "time_delay" || e == "backlash") return 0;
  return 1;
}
bool has_theta(const std::string& e) {
  return e == "creep" || e == "time_delay" || e == "periodic_interference" || e == "rate_dependent_hysteresis" ||
         e == "acceleration_dependence" || e == "backlash";
}

// Physical parameters of an effect from its nonlinear parameter theta and linear coefficients b.
json physical(const std::string& e, double theta, const VectorXd& b, const Context& cx, double c9) {
  json p;
  if (e == "static_nonlinearity") {
    p["quadratic_deg"] = b(0);
    p["cubic_deg"] = b(1);
    p["quartic_deg"] = b(2);
    p["quintic_deg"] = b(3);
    // The largest deviation from a straight line over 0..90 deg (what the paper's linearity bounds).
    double lo = kInf, hi = -kInf;
    for (int i = 0; i <= 90; ++i) {
      const double u = (i - 45.0) / 45.0, e2 = b(0) * u * u + b(1) * u * u * u + b(2) * u * u * u * u + b(3) * u * u * u * u * u;
      const double lin = (b(0) + b(2)) + (b(1) + b(3)) * u;  // the chord through the ends (u = -1, 1)
      lo = std::min(lo, e2 - lin);
      hi = std::max(hi, e2 - lin);
    }
    p["max_deviation_deg"] = std::abs(hi) > std::abs(lo) ? hi : lo;
  }
  else if (e == "drift") {
    p["drift_deg_per_min"] = b(0) / (cx.duration_s / 60.0);
  } else if (e == "creep") { p["tau_s"] = theta; p["gain"] = b(0); }
  else if (e == "rate_dependent_hysteresis") {
    p["amplitude_mv"] = b(0) * 1e3;
    p["amplitude_deg"] = b(0) * c9;
    p["velocity_scale_rad_s"] = theta;
    p["hysteresis_scale"] = 1.0 + b(1);
  } else if (e == "acceleration_dependence") { p["gain_deg_per_rad_s2"] = b(0); p["window_s"] = theta; }
  else if (e == "time_delay") { p["delay_ms"] = theta * 1e3; }
  else if (e == "backlash") { p["width_deg"] = theta; }
  else if (e == "source_power_coupling") { p["gamma"] = b(0); p["offset_v"] = b(1); }
  else if (e == "periodic_interference") {
    p["frequency_hz"] = theta;
    // Amplitude at the middle of the range (v = 3.37 V, 45 deg), and its reference-channel share.
    const double vm = cx.m.c10 / cx.m.c9 - 45.0 / cx.m.c9;
    const double amp = std::hypot(b(0) + vm * b(2), b(1) + vm * b(3));
    p["amplitude_mv"] = amp * 1e3;
    p["amplitude_deg"] = amp * c9;
    p["reference_share_mv_per_v"] = std::hypot(b(2), b(3)) * 1e3;
  }
  return p;
}

// Delete-one-block jackknife standard error of each physical parameter (robust to the strong
// autocorrelation of 200 Hz residuals, unlike the textbook least-squares covariance).
void add_jackknife(json& p, const std::vector<json>& folds) {
  if (folds.size() < 2) return;
  json se;
  for (auto it = p.begin(); it != p.end(); ++it) {
    double mean = 0;
    for (const json& f : folds) mean += f[it.key()].get<double>();
    mean /= static_cast<double>(folds.size());
    double ss = 0;
    for (const json& f : folds) ss += std::pow(f[it.key()].get<double>() - mean, 2);
    const double kk = static_cast<double>(folds.size());
    se[it.key() + "_se"] = std::sqrt((kk - 1) / kk * ss);
  }
  for (auto it = se.begin(); it != se.end(); ++it) p[it.key()] = it.value();
}

double lag1(const VectorXd& r) {
  const double m = r.mean();
  const VectorXd c = r.array() - m;
  const double den = c.squaredNorm();
  if (den <= 0) return 0;
  return c.head(c.size() - 1).dot(c.tail(c.size() - 1)) / den;
}

// Effective number of independent residuals (AR(1) approximation) for the BIC.
double effective_n(const VectorXd& r) {
  const double rho = std::clamp(lag1(r), 0.0, 0.999);
  return std::max(50.0, static_cast<double>(r.size()) * (1 - rho) / (1 + rho));
}

// Frequencies of the strongest spectral peak of r above 2 Hz (the movement itself is < 1 Hz) and a
// fine grid around it (1/30 of a bin) so the phase holds over the whole recording.
std::vector<double> interference_grid(const VectorXd& r, double dt) {
  Index nfft = 1;
  while (nfft < r.size()) nfft *= 2;
  std::vector<double> x(static_cast<std::size_t>(nfft), 0.0);
  const double m = r.mean();
  for (Index i = 0; i < r.size(); ++i) x[static_cast<std::size_t>(i)] = r(i) - m;
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> X;
  fft.fwd(X, x);
  const double df = 1.0 / (static_cast<double>(nfft) * dt);
  const auto lo = static_cast<std::size_t>(std::ceil(2.0 / df));
  const std::size_t hi = static_cast<std::size_t>(nfft / 2) - 2;
  std::size_t best = lo;
  double bp = -1;
  for (std::size_t i = lo; i < hi; ++i)
    if (std::norm(X[i]) > bp) { bp = std::norm(X[i]); best = i; }
  std::vector<double> grid;
  for (int j = -45; j <= 45; ++j) grid.push_back((static_cast<double>(best) + j / 30.0) * df);
  return grid;
}

std::vector<double> theta_grid(const std::string& e) {
  std::vector<double> g;
  if (e == "creep")
    // 1 .. 200 s. A memory shorter than ~1 s is, on the reference angle, indistinguishable from a
    // delay plus an acceleration term (LP(x) - x = -tau x' + tau^2 x'' - ...); viscoelastic creep
    // of the fibre shows as relaxation over seconds in the holds.
    for (int i = 0; i <= 20; ++i) g.push_back(std::pow(200.0, i / 20.0));
  else if (e == "rate_dependent_hysteresis")
    for (int i = 0; i <= 12; ++i) g.push_back(0.02 * std::pow(50.0, i / 12.0));    // w0 0.02 .. 1 rad/s
  else if (e == "rate_dependent_hysteresis")
    for (int i = 0; i <= 12; ++i) g.push_back(0.02 * std::pow(50.0, i / 12.0));    // w0 0.02 .. 1 rad/s
  else if (e == "acceleration_dependence")
    for (double h : {0.015, 0.025, 0.035, 0.05, 0.075, 0.1}) g.push_back(h);        // +-window [s]
  else if (e == "backlash")
    for (int i = 1; i <= 30; ++i) g.push_back(0.1 * i);                             // 0.1 .. 3 deg
  else if (e == "time_delay")
    for (int i = -25; i <= 25; ++i) g.push_back(i * 0.01);                          // +-250 ms
  else
    g.push_back(0.0);
  return g;
}

struct CandidateResult {
  std::string effect;
  bool applicable = true;
  std::string note;
  std::vector<double> grid;
  FoldFit fit;
  int n_params = 0;
};

struct CurrentFit {
  Design d;
  Grams grams;
  FoldFit fit;       // theta grid of size 1 (the state is fixed)
  VectorXd cv_resid; // held-out residual [V], block by block
};

VectorXd heldout_residual(const Design& d, const Blocks& b, const std::vector<VectorXd>& beta) {
  VectorXd r(d.y.size());
  for (std::size_t i = 0; i < b.size(); ++i)
    r.segment(b.start[i], b.len[i]) =
        d.y.segment(b.start[i], b.len[i]) - d.X.middleRows(b.start[i], b.len[i]) * beta[i];
  return r;
}

CurrentFit fit_state(const Context& cx, const State& st) {
  CurrentFit c;
  c.d = build_design(cx, st);
  c.grams = make_grams(c.d.X, c.d.y, cx.blocks);
  c.fit = cross_validate({c.grams});
  c.cv_resid = heldout_residual(c.d, cx.blocks, c.fit.beta);
  return c;
}

double full_rss(const Context& cx, const State& st) {
  const Design d = build_design(cx, st);
  const Grams g = make_grams(d.X, d.y, cx.blocks);
  return cross_validate({g}).full_rss;
}

// "Add it and refit" (docs/gap.md, step 4): once an effect joins, the nonlinear parameters of the terms
// already accepted are re-chosen on all the data with the others fixed (one coordinate pass), so a
// creep time constant fitted while a delay was still missing does not stay biased.
void refit_thetas(const Context& cx, State& st) {
  if (st.delay_s != 0) {
    double best = full_rss(cx, st), bd = st.delay_s;
    for (int j = -20; j <= 20; ++j) {
      if (j == 0) continue;
      State s2 = st;
      s2.delay_s = st.delay_s + j * 0.001;
      const double r = full_rss(cx, s2);
      if (r < best) { best = r; bd = s2.delay_s; }
    }
    st.delay_s = bd;
  }
  if (st.backlash_deg > 0) {
    double best = full_rss(cx, st), bb = st.backlash_deg;
    for (int j = -10; j <= 10; ++j) {
      State s2 = st;
      s2.backlash_deg = st.backlash_deg + j * 0.02;
      if (j == 0 || s2.backlash_deg <= 0) continue;
      const double r = full_rss(cx, s2);
      if (r < best) { best = r; bb = s2.backlash_deg; }
    }
    st.backlash_deg = bb;
  }
  for (Term& t : st.terms) {
    if (!has_theta(t.effect) || t.effect == "periodic_interference") continue;
    double best = full_rss(cx, st), bt = t.theta;
    for (double th : theta_grid(t.effect)) {
      t.theta = th;
      const double r = full_rss(cx, st);
      if (r < best) { best = r; bt = th; }
    }
    t.theta = bt;
  }
}

CandidateResult evaluate(const std::string& e, const Context& cx, const State& st, const CurrentFit& cur) {
  CandidateResult cr;
  cr.effect = e;
  cr.n_params = linear_count(e) + (has_theta(e) ? 1 : 0);
  for (const Term& t : st.terms)
    if (t.effect == e && !(e == "periodic_interference")) {
      cr.applicable = false;
      cr.note = "already in the model";
      return cr;
    }
  if ((e == "time_delay" && st.delay_s != 0) || (e == "backlash" && st.backlash_deg > 0)) {
    cr.applicable = false;
    cr.note = "already in the model";
    return cr;
  }
  if (e == "source_power_coupling" && std::sqrt(cx.s->ref_rel.squaredNorm() / static_cast<double>(cx.s->n)) < 1e-4) {
    cr.applicable = false;
    cr.note = "reference level constant (< 0.01 % RMS): coupling not identifiable";
    return cr;
  }
  cr.grid = e == "periodic_interference" ? interference_grid(cur.cv_resid, cx.s->dt) : theta_grid(e);
  std::vector<Grams> per;
  // Kinematic candidates rebuild the whole design for each grid value.
  auto eval_kin = [&](double th) {
    State s2 = st;
    (e == "time_delay" ? s2.delay_s : s2.backlash_deg) = th;
    const Design dd = build_design(cx, s2);
    return make_grams(dd.X, dd.y, cx.blocks);
  };
  if (e == "time_delay" || e == "backlash") {
    for (double d : cr.grid) per.push_back(e == "time_delay" && d == 0.0 ? cur.grams : eval_kin(d));
    // Refine (1 ms, 0.01 deg) around the coarse optimum (chosen on all data; per fold the grid
    // value is still chosen on training blocks only).
    const FoldFit coarse = cross_validate(per);
    const double c0 = cr.grid[coarse.full_idx];
    const double step = e == "time_delay" ? 0.001 : 0.01;
    const int reach = e == "time_delay" ? 9 : 9;
    for (int j = -reach; j <= reach; ++j) {
      if (j == 0 || c0 + j * step <= 0.0) continue;
      const double d = c0 + j * step;
      cr.grid.push_back(d);
      per.push_back(eval_kin(d));
    }
  } else {
    for (double th : cr.grid) {
      const MatrixXd C = effect_columns(e, th, cx, cur.d.k);
      per.push_back(extend_grams(cur.grams, cur.d.X, C, cur.d.y, cx.blocks));
    }
  }
  cr.fit = cross_validate(per);
  return cr;
}

std::string fmt(double x, int prec = 3) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(prec);
  o << x;
  return o.str();
}

}  // namespace

json Result::to_json() const {
  json j;
  j["baseline_gap_deg"] = baseline_gap_deg;
  j["steps"] = json::array();
  for (const Step& s : steps)
    j["steps"].push_back({{"effect", s.effect}, {"gap_deg", s.gap_deg}, {"where", s.where},
                          {"parameters", s.parameters}, {"evidence", s.evidence}});
  j["final_gap_deg"] = final_gap_deg;
  j["unexplained"] = unexplained;
  j["baseline"] = baseline;
  j["whiteness"] = whiteness;
  j["model"] = model;
  j["recording"] = recording;
  return j;
}

Result analyse(const io::Recording& rec, const Options& opt) {
  auto say = [&](const std::string& m) { if (opt.progress) opt.progress(m); };
  const Signals s = make_signals(rec);
  Context cx;
  cx.s = &s;
  cx.m = core::paper_coefficients();
  cx.p0 = 1.0 / cx.m.c9;
  cx.duration_s = s.t(s.n - 1) + s.dt;
  const Kinematics k0 = make_kinematics(s.angle, s.dt, 0.0, cx.m);
  const std::string src = rec.source.empty() ? std::string("recording") : rec.source;
  const Index moving = (k0.s_move.array() != 0).count();
  if (moving < s.n / 20 || moving > s.n - s.n / 20)
    throw pof::DataError(src + ": `pof gap` needs both holds and movements (the calibration protocol); " +
                        std::to_string(moving) + " of " + std::to_string(s.n) + " scans move");
  cx.blocks = make_blocks(k0, std::max(2, opt.folds));
  const std::vector<Phase> phases = classify_phases(k0, s.dt);

  Result res;
  res.recording = {{"scans", s.n}, {"rate_hz", 1.0 / s.dt}, {"duration_s", cx.duration_s},
                   {"reference_level_v", s.reference_level_v}, {"folds", cx.blocks.size()}};
  json bounds = json::array();
  for (std::size_t i = 0; i < cx.blocks.size(); ++i) bounds.push_back(s.t(cx.blocks.start[i]));
  res.recording["fold_start_s"] = bounds;

  State st;
  say("baseline: fitting the quasi-static line (c9, c10) with the paper's hysteresis chain");
  CurrentFit cur = fit_state(cx, st);
  const double N = static_cast<double>(s.n);
  auto c9_of = [](const VectorXd& beta) {
    if (beta.size() == 0 || beta.data() == nullptr) return 0.0;
    const double p = beta.data()[0];
    return p != 0 ? 1.0 / p : 0.0;
  };
  const double c9 = c9_of(cur.fit.beta_full);
  auto gap_deg = [&](double cv_rss) { return std::sqrt(cv_rss / N) * std::abs(c9); };
  // Residual in degrees: positive when the sensor reads a larger angle than the model (dv/dangle < 0).
  auto to_deg = [&](const VectorXd& r) { return VectorXd(-r * c9); };

  res.baseline_gap_deg = gap_deg(cur.fit.cv_rss);
  {
    const Localisation loc = localise(to_deg(cur.cv_resid), s, k0, phases);
    res.baseline = {{"c9_deg_per_v", c9}, {"c10_deg", cur.fit.beta_full(1) * c9}, {"kappa", cur.fit.beta_full(2)},
                    {"refit", "quasi-static line (c9, c10) and the reference-level scale kappa refitted by linear least "
                              "squares; f1-f4 (paper, table 2) kept"},
                    {"heldout_gap_deg", res.baseline_gap_deg}, {"where", loc.sentence}, {"localisation", loc.detail}};
  }
  say("baseline: held-out gap " + fmt(res.baseline_gap_deg) + " deg");
  const VectorXd resid_baseline = to_deg(cur.cv_resid);
  VectorXd model_baseline = s.v - cur.cv_resid;
  VectorXd strict_resid = cur.cv_resid;

  for (int step = 1; step <= opt.max_steps; ++step) {
    const auto& names = candidate_names();
    say("step " + std::to_string(step) + ": fitting " + std::to_string(names.size()) + " candidate effects");
    std::vector<CandidateResult> cands(names.size());
    // Two workers pull candidates off a shared index (the candidates are independent).
    std::atomic<std::size_t> next{0};
    auto worker = [&] {
      for (std::size_t i = next++; i < names.size(); i = next++) cands[i] = evaluate(names[i], cx, st, cur);
    };
    std::vector<std::future<void>> pool;
    for (int t = 1; t < std::max(1, opt.threads); ++t) pool.push_back(std::async(std::launch::async, worker));
    worker();
    for (auto& f : pool) f.get();

    const double n_eff = effective_n(cur.cv_resid);
    const double rss0 = cur.fit.cv_rss;
    json scores = json::object();
    std::size_t best = names.size();
    double best_bic = kInf;
    for (std::size_t i = 0; i < cands.size(); ++i) {
      const CandidateResult& c = cands[i];
      if (!c.applicable) { scores[c.effect] = {{"applicable", false}, {"note", c.note}}; continue; }
      const double red = 1.0 - std::sqrt(c.fit.cv_rss / rss0);
      const double dbic = n_eff * std::log(c.fit.cv_rss / rss0) + c.n_params * std::log(n_eff);
      scores[c.effect] = {{"heldout_gap_deg", gap_deg(c.fit.cv_rss)}, {"reduction_pct", 100 * red},
                          {"delta_bic", dbic}, {"parameters", c.n_params}};
      if (dbic < best_bic) { best_bic = dbic; best = i; }
    }
    if (best == names.size()) break;
    const CandidateResult& w = cands[best];
    const double red = 1.0 - std::sqrt(w.fit.cv_rss / rss0);
    const bool accept = red >= opt.min_reduction && -best_bic > opt.min_delta_bic;
    say("step " + std::to_string(step) + ": best " + w.effect + " (held-out gap " + fmt(gap_deg(rss0)) + " -> " +
        fmt(gap_deg(w.fit.cv_rss)) + " deg, " + fmt(100 * red, 1) + " %, dBIC " + fmt(best_bic, 1) + ")" +
        (accept ? ": accepted" : ": not significant, stopping"));
    if (!accept) {
      res.whiteness["last_rejected"] = {{"effect", w.effect}, {"reduction_pct", 100 * red}, {"delta_bic", best_bic},
                                        {"all", scores}};
      break;
    }
    // The held-out residual after the step, fold by fold with the fold's own (training) fit.
    const Index k0cols = cur.d.X.cols();
    VectorXd after(s.n);
    std::vector<json> fold_params;
    for (std::size_t f = 0; f < cx.blocks.size(); ++f) {
      const double th = w.grid.empty() ? 0.0 : w.grid[w.fit.theta_idx[f]];
      State s2 = st;
      if (w.effect == "time_delay") s2.delay_s = th;
      else if (w.effect == "backlash") s2.backlash_deg = th;
      else s2.terms.push_back({w.effect, th});
      const Design d2 = build_design(cx, s2);
      const Index a = cx.blocks.start[f], l = cx.blocks.len[f];
      after.segment(a, l) = d2.y.segment(a, l) - d2.X.middleRows(a, l) * w.fit.beta[f];
      const VectorXd bf = w.fit.beta[f];
      fold_params.push_back(physical(w.effect, th, bf.tail(bf.size() - k0cols), cx, c9_of(bf)));
    }
    const double th_full = w.grid.empty() ? 0.0 : w.grid[w.fit.full_idx];
    const VectorXd bfull = w.fit.beta_full;
    json params = physical(w.effect, th_full, bfull.tail(bfull.size() - k0cols), cx, c9_of(bfull));
    add_jackknife(params, fold_params);
    // A grid parameter is known no better than its grid: the standard error is at least the
    // spacing at the chosen value / sqrt(12) (a jackknife of identical grid picks says 0).
    if (has_theta(w.effect) && w.grid.size() > 1) {
      static const std::map<std::string, std::pair<std::string, double>> key{
          {"creep", {"tau_s", 1.0}}, {"time_delay", {"delay_ms", 1e3}}, {"rate_dependent_hysteresis", {"velocity_scale_rad_s", 1.0}},
          {"acceleration_dependence", {"window_s", 1.0}}, {"periodic_interference", {"frequency_hz", 1.0}},
          {"backlash", {"width_deg", 1.0}}};
      const auto& [name, scale] = key.at(w.effect);
      double spacing = kInf;
      for (std::size_t i = 0; i < w.grid.size(); ++i)
        if (i != w.fit.full_idx && std::abs(w.grid[i] - th_full) > 0) spacing = std::min(spacing, std::abs(w.grid[i] - th_full));
      const double floor_se = scale * spacing / std::sqrt(12.0);
      if (std::isfinite(floor_se) && params[name + "_se"].get<double>() < floor_se) params[name + "_se"] = floor_se;
    }

    // Where: the part of the residual this effect explains, localised.
    const VectorXd explained = to_deg(VectorXd(cur.cv_resid - after));
    const Localisation loc = localise(explained, s, k0, phases);
    const Localisation before_loc = localise(to_deg(cur.cv_resid), s, k0, phases);
    Step stp;
    stp.effect = w.effect;
    stp.gap_deg = gap_deg(w.fit.cv_rss);
    stp.where = loc.sentence;
    stp.parameters = params;
    std::vector<std::pair<double, std::string>> ranked;
    for (const auto& c : cands)
      if (c.applicable) ranked.emplace_back(scores[c.effect]["delta_bic"].get<double>(), c.effect);
    std::sort(ranked.begin(), ranked.end());
    stp.evidence = {{"heldout_gap_before_deg", gap_deg(rss0)},
                    {"heldout_gap_after_deg", stp.gap_deg},
                    {"reduction_pct", 100 * red},
                    {"delta_bic", best_bic},
                    {"n_eff", n_eff},
                    {"runner_up", ranked.size() > 1 ? ranked[1].second : std::string()},
                    {"runner_up_delta_bic", ranked.size() > 1 ? ranked[1].first : 0.0},
                    {"residual_before_where", before_loc.sentence},
                    {"phase_rms_before_deg", phase_rms(to_deg(cur.cv_resid), phases)},
                    {"phase_rms_after_deg", phase_rms(to_deg(after), phases)},
                    {"explained_localisation", loc.detail},
                    {"candidates", scores}};
    res.steps.push_back(stp);
    if (w.effect == "time_delay") st.delay_s = th_full;
    else if (w.effect == "backlash") st.backlash_deg = th_full;
    else st.terms.push_back({w.effect, th_full});
    if (st.terms.size() + (st.delay_s != 0 ? 1 : 0) + (st.backlash_deg > 0 ? 1 : 0) > 1) refit_thetas(cx, st);
    // The next ranking compares candidates with the state refitted the same way they are (accepted
    // nonlinear parameters fixed); the reported gaps stay the strict per-fold ones.
    cur = fit_state(cx, st);
    strict_resid = after;
  }
  res.final_gap_deg = res.steps.empty() ? res.baseline_gap_deg : res.steps.back().gap_deg;

  // ---- whiteness of what is left ----------------------------------------------------------------
  const VectorXd rf = to_deg(strict_resid);
  {
    const VectorXd c = rf.array() - rf.mean();
    const double den = c.squaredNorm();
    json acf = json::object();
    double q = 0;
    const int L = 20;
    for (int lag = 1; lag <= 200; ++lag) {
      const auto l = static_cast<Index>(lag);
      const double r = den > 0 ? c.head(s.n - l).dot(c.tail(s.n - l)) / den : 0.0;
      if (lag <= L) q += r * r / (N - lag);
      if (lag == 1 || lag == 2 || lag == 5 || lag == 10 || lag == 20 || lag == 50 || lag == 100 || lag == 200)
        acf[std::to_string(lag)] = r;
    }
    q *= N * (N + 2);
    Eigen::VectorXd dif = rf.tail(s.n - 1) - rf.head(s.n - 1);
    const double floor = std::sqrt(dif.squaredNorm() / static_cast<double>(dif.size()) / 2.0);
    const double rms = std::sqrt(c.squaredNorm() / N);
    const double ratio = floor > 0 ? rms / floor : 1.0;
    // Structure remains when the residual is far from white: its RMS exceeds the scan-to-scan noise
    // floor by > 25 % (> 36 % of its variance is slow) and Ljung-Box rejects whiteness at 5 %.
    res.unexplained = ratio > 1.25 && q > 31.41;
    res.whiteness["acf_lag_scans"] = acf;
    res.whiteness["acf_95_band"] = 1.96 / std::sqrt(N);
    res.whiteness["ljung_box_q20"] = q;
    res.whiteness["ljung_box_crit_5pct"] = 31.41;
    res.whiteness["noise_floor_deg"] = floor;
    res.whiteness["rms_over_noise_floor"] = ratio;
    res.whiteness["final_where"] = localise(rf, s, k0, phases).sentence;
  }

  // ---- improved model, fitted on all the data ----------------------------------------------------
  {
    const VectorXd b = cur.fit.beta_full;
    const double c9f = c9_of(b);
    core::ModelCoefficients mm = cx.m;
    mm.c9 = b(2) * c9f;  // in the units of v_model = v_norm / kappa (reference level rescaled)
    mm.c10 = b(1) * c9f;
    json terms = json::array();
    Index c = kBaseCols;
    for (const Term& t : st.terms) {
      const auto nl = static_cast<Index>(linear_count(t.effect));
      const VectorXd bt = b.segment(c, nl);
      std::vector<double> coef(bt.data(), bt.data() + bt.size());
      terms.push_back({{"effect", t.effect}, {"theta", t.theta}, {"coefficients_v", coef},
                       {"parameters", physical(t.effect, t.theta, bt, cx, c9f)}});
      c += nl;
    }
    res.model = {{"c1", mm.c1}, {"c2", mm.c2}, {"c9", mm.c9}, {"c10", mm.c10},
                 {"flexion", {mm.flexion.c3, mm.flexion.c4, mm.flexion.c5, mm.flexion.c6, mm.flexion.c7, mm.flexion.c8}},
                 {"extension", {mm.extension.c3, mm.extension.c4, mm.extension.c5, mm.extension.c6, mm.extension.c7, mm.extension.c8}},
                 {"reference_level_v", s.reference_level_v / b(2)}, {"kappa", b(2)}, {"delay_s", st.delay_s}, {"backlash_deg", st.backlash_deg}, {"duration_s", cx.duration_s},
                 {"terms", terms}};
    // Range and quasi-static quality, for the calibration-file layout (docs/calibration.md).
    double wmax = 0;
    Index n_holds = 0, run = 0;
    double sa = 0, sv = 0, saa = 0, svv = 0, sav = 0, nh = 0;
    for (Index i = 0; i < s.n; ++i) {
      wmax = std::max(wmax, std::abs(k0.w(i)));
      if (k0.s_move(i) == 0) {
        if (++run == static_cast<Index>(3.0 / s.dt)) ++n_holds;  // holds of >= 3 s
        const double a = s.angle(i), v = s.v(i);
        sa += a; sv += v; saa += a * a; svv += v * v; sav += a * v; nh += 1;
      } else {
        run = 0;
      }
    }
    const double cov = sav - sa * sv / nh, va = saa - sa * sa / nh, vv = svv - sv * sv / nh;
    res.model["range"] = {{"angle_min_deg", s.angle.minCoeff()}, {"angle_max_deg", s.angle.maxCoeff()},
                          {"velocity_min_rad_s", kHoldSpeedRadS}, {"velocity_max_rad_s", std::max(2 * kHoldSpeedRadS, wmax)}};
    res.model["linearity_r2"] = va > 0 && vv > 0 ? cov * cov / (va * vv) : 0.0;
    res.model["n_holds"] = n_holds;
  }

  // ---- plot series (at most ~40k rows) ----------------------------------------------------------
  const Index stride = std::max<Index>(1, s.n / 40000);
  const VectorXd model_final = s.v - strict_resid;
  for (Index i = 0; i < s.n; i += stride) {
    res.series.t.push_back(s.t(i));
    res.series.angle.push_back(s.angle(i));
    res.series.w.push_back(k0.w(i));
    res.series.v.push_back(s.v(i));
    res.series.model_baseline.push_back(model_baseline(i));
    res.series.model_final.push_back(model_final(i));
    res.series.resid_baseline_deg.push_back(resid_baseline(i));
    res.series.resid_final_deg.push_back(rf(i));
  }
  say("done: held-out gap " + fmt(res.baseline_gap_deg) + " -> " + fmt(res.final_gap_deg) + " deg in " +
      std::to_string(res.steps.size()) + " step(s)");
  return res;
}

}  // namespace pof::gap
