#pragma once
// Least-squares fits used by the calibration (table 2 of Leal-Junior et al. 2017): straight lines
// (f2, f3, f4, f5) and the exponential f1. Every fit reports its residuals and the standard errors
// of its parameters (ordinary least squares: cov = s^2 (J^T J)^-1, s^2 = SSR / (n - p)).
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Core>

namespace pof::core {

/// A step shortened until it is taken: trial(scale) for scale = 1, 1/2, ..., 2^-max_halvings, the
/// first result it gives (a trial returns an empty std::optional to refuse a scale); empty when
/// every scale was refused. The fits' damped steps (`pof gap`'s structure moves) all go this way.
template <class Trial>
auto halving_search(Trial&& trial, int max_halvings = 8) -> decltype(trial(1.0)) {
  double scale = 1;
  for (int halving = 0; halving <= max_halvings; ++halving, scale /= 2)
    if (auto taken = trial(scale)) return taken;
  return {};
}

/// y = slope * x + intercept.
struct LinearFit {
  double slope = 0, intercept = 0;
  double slope_se = 0, intercept_se = 0;  // standard errors
  double r2 = 0;                          // coefficient of determination ("linearity" in the paper)
  double rmse = 0;                        // root mean square of the residuals
  Eigen::Index n = 0;
  Eigen::VectorXd residuals;              // y - fit, one per point

  [[nodiscard]] double operator()(double x) const { return slope * x + intercept; }
};

/// Ordinary least squares line through (x, y). Needs n >= 2 and x not constant; otherwise returns
/// n = 0 and NaN parameters (callers check ok()).
LinearFit fit_line(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& y);

/// f1: y = c1 exp(c2 x). Started from the log-linear fit, refined by Gauss-Newton on the linear
/// residuals (the log fit alone over-weights the small values).
struct ExpFit {
  double c1 = 0, c2 = 0;
  double c1_se = 0, c2_se = 0;
  double r2 = 0, rmse = 0;
  int iterations = 0;
  bool converged = false;
  Eigen::VectorXd residuals;

  [[nodiscard]] double operator()(double x) const;
};

/// Needs n >= 2 and y > 0. Throws std::invalid_argument otherwise.
ExpFit fit_exponential(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& y);

/// A line fitted from running sums (Welford-style co-moments): O(1) per point, no allocation, so
/// the online statistics can use it per scan.
struct LineAccumulator {
  double n = 0, mean_x = 0, mean_y = 0, sxx = 0, sxy = 0, syy = 0;
  double x_min = std::numeric_limits<double>::infinity();
  double x_max = -std::numeric_limits<double>::infinity();

  void add(double x, double y) {
    n += 1;
    const double dx = x - mean_x;
    mean_x += dx / n;
    const double dy = y - mean_y;
    mean_y += dy / n;
    sxx += dx * (x - mean_x);
    sxy += dx * (y - mean_y);
    syy += dy * (y - mean_y);
    if (x < x_min) x_min = x;
    if (x > x_max) x_max = x;
  }
  void clear() { *this = LineAccumulator{}; }
  [[nodiscard]] bool ok() const { return n >= 2 && sxx > 0; }
  [[nodiscard]] double slope() const { return sxy / sxx; }
  [[nodiscard]] double intercept() const { return mean_y - slope() * mean_x; }
  [[nodiscard]] double at(double x) const { return mean_y + slope() * (x - mean_x); }
};

/// Hysteresis of one loop by eq. (1): H% = (Ymn - Ymp) / (Ymax - Ymin) * 100, where Ymn - Ymp is the
/// vertical distance between the linear approximations of the extension (unloading) and flexion
/// (loading) curves at the middle of the cycle, and Ymax - Ymin the span of the response. The span
/// is taken from the fitted lines at the ends of the common x range, not from raw extremes, so
/// that noise does not inflate it. pct is signed (extension minus flexion).
struct Hysteresis {
  double pct = std::numeric_limits<double>::quiet_NaN();
  double x_mid = 0, y_flexion_mid = 0, y_extension_mid = 0, span = 0;
  bool valid = false;
};
Hysteresis hysteresis_eq1(const LineAccumulator& flexion, const LineAccumulator& extension);

}  // namespace pof::core

namespace pof::core {

/// Least squares with sign constraints, from the normal equations G = X^T X, g = X^T y:
/// minimise |y - X b|^2 subject to b_i >= 0 for every i with nonneg[i] set (the others are free).
/// Lawson & Hanson, "Solving Least Squares Problems" (1974), ch. 23 (NNLS), with the free
/// variables always in the passive set. Columns are Jacobi-scaled and a 1e-10 ridge keeps an
/// all-zero column at 0. Returns false if the active-set loop does not converge in 4 p iterations
/// (b then holds the last feasible point).
bool nnls_normal(const Eigen::Ref<const Eigen::MatrixXd>& G, const Eigen::Ref<const Eigen::VectorXd>& g,
                 const std::vector<bool>& nonneg, Eigen::VectorXd& b);

/// Least squares from the normal equations with the coefficients [first, first + size) all >= 0
/// or all <= 0, whichever leaves the smaller residual; the others free. A bank of stop operators
/// (Maxwell-slip elements) with weights of one sign runs every loop, major or minor, the same way
/// round (docs/calibration.md, "Why stop operators"). Two nnls_normal solves on the flipped
/// system (S G S, S g; S = -1 on the group for the second); size 0: one, every coefficient free.
Eigen::VectorXd one_signed_least_squares(const Eigen::Ref<const Eigen::MatrixXd>& G,
                                         const Eigen::Ref<const Eigen::VectorXd>& g, Eigen::Index first,
                                         Eigen::Index size);

}  // namespace pof::core
