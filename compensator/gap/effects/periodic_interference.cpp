// periodic_interference: pick-up at one frequency (docs/gap.md, section 3).
#include <cmath>
#include <complex>
#include <numbers>

#include <unsupported/Eigen/FFT>

#include "effect.hpp"

namespace pof::gap {
namespace periodic_interference_effect {  // named: the effects share unity batches (CMakeLists.txt)
namespace {

// The FFT's length for a recording of n scans (the next power of two) and so its bin width [Hz].
Eigen::Index fft_length(Eigen::Index n) {
  Eigen::Index nfft = 1;
  while (nfft < n) nfft *= 2;
  return nfft;
}
double bin_hz(const Context& cx) { return 1.0 / (static_cast<double>(fft_length(cx.s->n)) * cx.s->dt); }

// The strongest spectral peak of the residual above 2 Hz (the movement itself is < 1 Hz) and a grid
// of 1/6 bin over +-1.5 bins around it, refined to 1/30 of a bin around the best (refine) so the
// phase holds over the whole recording. A line's fit varies with its frequency on the scale of the
// main lobe, two bins wide: the coarse step finds the lobe, the fine one its top.
std::vector<double> grid(const Context& cx, const Eigen::VectorXd& r) {
  const Eigen::Index nfft = fft_length(r.size());
  std::vector<double> x(static_cast<std::size_t>(nfft), 0.0);
  const double m = r.mean();
  for (Eigen::Index i = 0; i < r.size(); ++i) x[static_cast<std::size_t>(i)] = r(i) - m;
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> X;
  fft.fwd(X, x);
  const double df = bin_hz(cx);
  const auto lo = static_cast<std::size_t>(std::ceil(2.0 / df));
  const std::size_t hi = static_cast<std::size_t>(nfft / 2) - 2;
  std::size_t best = lo;
  double bp = -1;
  for (std::size_t i = lo; i < hi; ++i)
    if (std::norm(X[i]) > bp) { bp = std::norm(X[i]); best = i; }
  std::vector<double> g;
  for (int j = -9; j <= 9; ++j) g.push_back((static_cast<double>(best) + j / 6.0) * df);
  return g;
}

std::vector<double> refine(double best, const Context& cx) {
  std::vector<double> g;
  for (int j = -4; j <= 4; ++j)
    if (j != 0) g.push_back(best + j / 30.0 * bin_hz(cx));
  return g;
}

// A sinusoid at f (mains, vibration) picked up on the sensor channel, plus the same pick-up on the
// reference channel, which the normalisation v = sensor L / reference turns into -v dR/L: an
// amplitude proportional to the level v (hence the v-weighted pair).
Eigen::MatrixXd columns(double f, const Context& cx, const Kinematics& k) {
  const Eigen::VectorXd vq = basis::quasi_static_v(cx, k);
  Eigen::MatrixXd C(cx.s->n, 4);
  const double om = 2.0 * std::numbers::pi * f;
  for (Eigen::Index i = 0; i < cx.s->n; ++i) {
    sincos(om * cx.s->t(i), &C(i, 0), &C(i, 1));  // glibc: sin and cos in one call, the same bits
    C(i, 2) = vq(i) * C(i, 0);
    C(i, 3) = vq(i) * C(i, 1);
  }
  return C;
}

nlohmann::json physical(double f, const Eigen::VectorXd& b, const Context& cx) {
  // Amplitude at the middle of the range (45 deg), and its reference-channel share.
  const double vm = core::quasi_static_voltage(cx.m, 45.0);
  const double amp = std::hypot(b(0) + vm * b(2), b(1) + vm * b(3));
  return {{"frequency_hz", f}, {"amplitude_mv", amp * 1e3}, {"amplitude_deg", amp * std::abs(cx.m.c9)},
          {"reference_share_mv_per_v", std::hypot(b(2), b(3)) * 1e3}};
}

}  // namespace
}  // namespace periodic_interference_effect

extern const EffectDef kPeriodicInterference{
    .id = core::Effect::kPeriodicInterference,
    .meaning = "pick-up at one frequency (mains, motor vibration) on the sensor and reference channels",
    .linear = 4,
    .theta_key = "frequency_hz",
    .magnitude_key = "amplitude_mv",
    .grid = periodic_interference_effect::grid,
    .refine = periodic_interference_effect::refine,
    .columns = periodic_interference_effect::columns,
    .physical = periodic_interference_effect::physical,
};

}  // namespace pof::gap
