// Whiteness of the final residual (see whiteness.hpp).
#include "whiteness.hpp"

#include <cmath>
#include <string>

namespace pof::gap {

double noise_floor(const Eigen::VectorXd& r) {
  const Eigen::Index n = r.size();
  if (n < 2) return 0;
  const Eigen::VectorXd dif = r.tail(n - 1) - r.head(n - 1);
  return std::sqrt(dif.squaredNorm() / static_cast<double>(dif.size()) / 2.0);
}

Whiteness whiteness(const Eigen::VectorXd& rf) {
  Whiteness w;
  const Eigen::Index n = rf.size();
  const double N = static_cast<double>(n);
  const Eigen::VectorXd c = rf.array() - rf.mean();
  const double den = c.squaredNorm();
  nlohmann::json acf = nlohmann::json::object();
  double q = 0;
  constexpr int kLjungBoxLags = 20;
  for (int lag = 1; lag <= 200 && lag < n; ++lag) {
    const auto l = static_cast<Eigen::Index>(lag);
    const double r = den > 0 ? c.head(n - l).dot(c.tail(n - l)) / den : 0.0;
    if (lag <= kLjungBoxLags) q += r * r / (N - lag);
    if (lag == 1 || lag == 2 || lag == 5 || lag == 10 || lag == 20 || lag == 50 || lag == 100 || lag == 200)
      acf[std::to_string(lag)] = r;
  }
  q *= N * (N + 2);
  const double floor = noise_floor(rf);
  const double rms = std::sqrt(c.squaredNorm() / N);
  const double ratio = floor > 0 ? rms / floor : 1.0;
  constexpr double kLjungBoxCritical = 31.41;  // chi^2(20) at 5 %
  w.unexplained = ratio > 1.25 && q > kLjungBoxCritical;
  w.detail = {{"acf_lag_scans", acf},        {"acf_95_band", 1.96 / std::sqrt(N)},
              {"ljung_box_q20", q},          {"ljung_box_crit_5pct", kLjungBoxCritical},
              {"noise_floor_deg", floor},    {"rms_over_noise_floor", ratio}};
  return w;
}

}  // namespace pof::gap
