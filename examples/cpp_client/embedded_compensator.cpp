// pof-embedded-compensator: the pure model (pofkit::core) inside a controller's own process, for a
// controller that reads the DAQ itself and wants no bus hop. It feeds the paper's own sensor
// (table-2 coefficients, Leal-Junior et al. 2017) a flexion-extension sweep at 0.3 rad/s through
// model_voltage() (eqs. (11)/(12) forward) and compensates it scan by scan with OnlineCompensator,
// as pof-compensatord does. Prints the error against the true angle; exits 1 if it exceeds 2 deg
// away from the reversals (where the velocity estimate lags, see compensator.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "pof/core/calibration.hpp"
#include "pof/core/compensator.hpp"
#include "pof/core/model.hpp"

int main() {
  pof::core::Calibration cal;
  cal.model = pof::core::paper_coefficients();
  pof::core::CompensatorSettings settings;  // 200 Hz, the paper's velocity window
  pof::core::OnlineCompensator comp(cal, settings);

  const double rate_hz = settings.scan_rate_hz, w = 0.3;  // rad/s
  const double sweep_s = (80.0 * M_PI / 180.0) / w;         // 10 -> 90 deg
  double worst = 0;
  for (int k = 0; k < static_cast<int>(2 * sweep_s * rate_hz); ++k) {
    const double t = k / rate_hz;
    const bool up = t < sweep_s;
    const double angle = up ? 10 + w * t * 180 / M_PI : 90 - w * (t - sweep_s) * 180 / M_PI;
    const auto dir = up ? pof::core::Direction::kFlexion : pof::core::Direction::kExtension;
    const double v = pof::core::model_voltage(cal.model, angle, w, dir);
    const pof::core::CompensatedScan s = comp.step(v, cal.reference_level_v);
    const double from_reversal = std::min(t, std::abs(t - sweep_s));
    if (from_reversal > 1.0 && (s.quality & pof::core::quality::kSettling) == 0)
      worst = std::max(worst, std::abs(s.angle_deg - angle));
  }
  std::printf("embedded compensator: worst error %.3f deg away from reversals (%d scans)\n", worst,
              static_cast<int>(2 * sweep_s * rate_hz));
  return worst <= 2.0 ? 0 : 1;
}
