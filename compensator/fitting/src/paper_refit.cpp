// The paper's structure refitted in the voltage domain (see paper_refit.hpp).
#include "pof/core/paper_refit.hpp"

#include <cmath>

#include <Eigen/Dense>

namespace pof::core {

const std::array<std::string_view, kRefitParameters> kRefitParameterNames{
    "c2", "c9", "c10", "flexion.c3", "flexion.c4", "flexion.c5", "flexion.c6",
    "extension.c3", "extension.c4", "extension.c5", "extension.c6"};

std::array<double, kRefitParameters> refit_parameters(const ModelCoefficients& m) {
  return {m.c2, m.c9, m.c10, m.flexion.c3, m.flexion.c4, m.flexion.c5, m.flexion.c6,
          m.extension.c3, m.extension.c4, m.extension.c5, m.extension.c6};
}

ModelCoefficients with_refit_parameters(ModelCoefficients m, const std::array<double, kRefitParameters>& p) {
  m.c2 = p[0];
  m.c9 = p[1];
  m.c10 = p[2];
  m.flexion.c3 = p[3];
  m.flexion.c4 = p[4];
  m.flexion.c5 = p[5];
  m.flexion.c6 = p[6];
  m.extension.c3 = p[7];
  m.extension.c4 = p[8];
  m.extension.c5 = p[9];
  m.extension.c6 = p[10];
  return m;
}

double model_voltage_gradient(const ModelCoefficients& m, double angle, double speed, Direction d, double* g) {
  for (int i = 0; i < kRefitParameters; ++i) g[i] = 0;
  const double v2 = (m.c10 - angle) / m.c9;
  if (d == Direction::kHold) {  // f5 alone
    g[1] = -v2 / m.c9;
    g[2] = 1.0 / m.c9;
    return v2;
  }
  const DirectionCoefficients& x = m.of(d);
  const double e = std::exp(m.c2 * speed), h = m.c1 * e;
  const double a = x.c3 * h + x.c4, b = x.c5 * h + x.c6;
  const double v1 = (v2 + x.c8) / x.c7;
  const double v = (v1 - b) / a;
  // dv/dV1 = 1/a, dv/da = -v/a, dv/db = -1/a; V1 = (V2 + c8)/c7, V2 = (c10 - angle)/c9.
  const double dv_dh = (-v * x.c3 - x.c5) / a;
  g[0] = dv_dh * h * speed;                   // c2 (h = c1 e^{c2 |w|})
  g[1] = -v2 / (m.c9 * x.c7 * a);             // c9
  g[2] = 1.0 / (m.c9 * x.c7 * a);             // c10
  const int o = d == Direction::kFlexion ? 3 : 7;
  g[o + 0] = -v / a * h;                      // c3
  g[o + 1] = -v / a;                          // c4
  g[o + 2] = -h / a;                          // c5
  g[o + 3] = -1.0 / a;                        // c6
  return v;
}

namespace {

bool gain_ok(const ModelCoefficients& m, const DirectionCoefficients& x, double speed) {
  const double gain = x.c7 * (x.c3 * hysteresis_pct(m, speed) + x.c4);
  return gain >= kChainGainMin && gain <= kChainGainMax;  // false for NaN
}

}  // namespace

bool chain_admissible(const ModelCoefficients& m, double max_speed_rad_s) {
  if (!std::isfinite(m.c9) || m.c9 == 0 || !std::isfinite(m.c10) || !std::isfinite(m.c1) || !std::isfinite(m.c2))
    return false;
  for (const DirectionCoefficients* x : {&m.flexion, &m.extension}) {
    if (!std::isfinite(x->c5) || !std::isfinite(x->c6) || !std::isfinite(x->c8)) return false;
    if (!gain_ok(m, *x, 0.0) || !gain_ok(m, *x, std::abs(max_speed_rad_s))) return false;
  }
  return true;
}

namespace {

// Sum of squared residuals and the normal equations at m over the rows used; false if the chain
// gain leaves [kChainGainMin, kChainGainMax] somewhere (chain_admissible) or a value is not finite.
bool normal_equations(const ModelCoefficients& m, const Eigen::VectorXd& angle, const Eigen::VectorXd& speed,
                      const std::vector<Direction>& dir, const Eigen::VectorXd& v, int stride, Eigen::MatrixXd* G,
                      Eigen::VectorXd* gv, double* ssr, Eigen::Index* rows) {
  constexpr int P = kRefitParameters;
  Eigen::Matrix<double, P, P> GG = Eigen::Matrix<double, P, P>::Zero();
  Eigen::Matrix<double, P, 1> gg = Eigen::Matrix<double, P, 1>::Zero();
  Eigen::Matrix<double, P, 1> row;
  double s = 0;
  Eigen::Index n = 0;
  for (Eigen::Index i = 0; i < v.size(); i += stride) {
    const Direction d = dir[static_cast<std::size_t>(i)];
    if (d != Direction::kHold) {
      const DirectionCoefficients& x = m.of(d);
      if (!gain_ok(m, x, speed(i))) return false;
    }
    const double mv = model_voltage_gradient(m, angle(i), speed(i), d, row.data());
    const double r = v(i) - mv;
    if (!std::isfinite(r)) return false;
    s += r * r;
    if (G != nullptr) {
      GG.selfadjointView<Eigen::Lower>().rankUpdate(row);
      gg += row * r;
    }
    ++n;
  }
  if (G != nullptr) {
    *G = GG.selfadjointView<Eigen::Lower>();
    *gv = gg;
  }
  *ssr = s;
  *rows = n;
  return true;
}

}  // namespace

PaperRefit refit_paper_model(const ModelCoefficients& m0, const Eigen::VectorXd& angle, const Eigen::VectorXd& speed,
                             const std::vector<Direction>& dir, const Eigen::VectorXd& v, int stride) {
  PaperRefit out;
  out.model = m0;
  stride = std::max(1, stride);
  Eigen::MatrixXd G;
  Eigen::VectorXd g;
  double ssr = 0;
  Eigen::Index rows = 0;
  if (!normal_equations(m0, angle, speed, dir, v, stride, &G, &g, &ssr, &rows) || rows == 0) return out;
  out.rms_before_v = out.rms_after_v = std::sqrt(ssr / static_cast<double>(rows));
  double lambda = 1e-3;
  for (int it = 0; it < 50; ++it) {
    out.iterations = it + 1;
    // Marquardt's scaling: damp each parameter by its own curvature, so c10 [deg] and c3 [1/%]
    // are stepped on comparable terms.
    Eigen::MatrixXd A = G;
    for (Eigen::Index k = 0; k < A.rows(); ++k) A(k, k) += lambda * std::max(G(k, k), 1e-300);
    const Eigen::VectorXd step = A.ldlt().solve(g);
    std::array<double, kRefitParameters> p = refit_parameters(out.model);
    for (int k = 0; k < kRefitParameters; ++k) p[static_cast<std::size_t>(k)] += step(k);
    const ModelCoefficients trial = with_refit_parameters(out.model, p);
    double ssr_t = 0;
    Eigen::Index rows_t = 0;
    Eigen::MatrixXd Gt;
    Eigen::VectorXd gt;
    if (step.allFinite() && normal_equations(trial, angle, speed, dir, v, stride, &Gt, &gt, &ssr_t, &rows_t) &&
        ssr_t < ssr) {
      const double gain = (ssr - ssr_t) / ssr;
      out.model = trial;
      G = std::move(Gt);
      g = std::move(gt);
      ssr = ssr_t;
      lambda = std::max(1e-9, lambda / 10);
      if (gain < 1e-10) { out.converged = true; break; }
    } else {
      lambda *= 10;
      if (lambda > 1e8) { out.converged = true; break; }  // no step lowers the residual: at a minimum
    }
  }
  out.rms_after_v = std::sqrt(ssr / static_cast<double>(rows));
  return out;
}

}  // namespace pof::core
