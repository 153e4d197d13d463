#pragma once
// What is left after the search: is the final residual white? (docs/gap.md, section 4)
#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace pof::gap {

struct Whiteness {
  nlohmann::json detail;     // ACF at lags, Ljung-Box Q(20), noise floor, their ratio
  bool unexplained = false;  // slow structure remains
};

/// r: the final held-out residual [deg]. Structure remains when its RMS exceeds the scan-to-scan
/// noise floor std(diff r)/sqrt 2 by > 25 % (> 36 % of its variance is slow) and Ljung-Box Q(20)
/// rejects whiteness at 5 % (critical value 31.41).
Whiteness whiteness(const Eigen::VectorXd& r);

/// The scan-to-scan noise floor of a residual r [deg]: std(diff r)/sqrt 2, what white noise alone
/// would give (no slow structure in it).
double noise_floor(const Eigen::VectorXd& r);

}  // namespace pof::gap
