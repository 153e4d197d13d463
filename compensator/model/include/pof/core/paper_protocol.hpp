#pragma once
// The test protocol of Leal-Junior et al. 2017 (Meas. Sci. Technol. 28 125103), defined once:
// the calibration's dynamic tests (table 1) and the validation cycles (table 3). The simulator's
// scenarios, the calibration's velocity range, the test generators and the tests read them here.
#include <array>

namespace pof::core {

/// Table 1: the constant angular velocities of the dynamic calibration tests [rad/s]. The paper
/// prints test 5 as "0.898"; 0.0898 is meant (it lies between tests 4 and 6, and 0.898 rad/s is
/// twice the fastest test).
inline constexpr std::array<double, 9> kTable1Velocities{0.0209, 0.0273, 0.0419, 0.0561, 0.0898,
                                                          0.1047, 0.1726, 0.3415, 0.4304};
/// Table 3: the validation velocities [rad/s] (3 flexion/extension cycles each, 10-80 deg).
inline constexpr std::array<double, 5> kTable3Velocities{0.05, 0.10, 0.16, 0.21, 0.26};

}  // namespace pof::core
