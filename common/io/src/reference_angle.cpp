#include "pof/base/errors.hpp"
#include "pof/io/recording_reader.hpp"

namespace pof::io {

Eigen::VectorXd reference_angle(const Recording& r, const pof::core::PotentiometerCalibration* pot) {
  if (pot && r.pot_v.size() == r.size()) return pot->angles(r.pot_v);
  if (r.angle_ref_deg.size() == r.size()) return r.angle_ref_deg;
  if (r.pot_v.size() == r.size())
    throw ConfigError(r.source + ": the recording has pot_v but no angle_ref_deg; give a potentiometer calibration "
                      "(--pot-cal <file.toml> with a [potentiometer] section: deg_per_volt, zero_v)");
  throw DataError(r.source + ": the recording has neither angle_ref_deg nor pot_v");
}

}  // namespace pof::io
