#pragma once
// The `pof compensate --csv` format (other tools read it, keep the names; docs/calibration.md):
//   t_s,angle_deg,angle_uncomp_deg,angle_ref_deg,velocity_rad_s,phase,quality
// phase: flexion|extension|hold; quality: the angle_t.QUALITY_* bits of the scan, as POF_ANGLE has them.
#include <cstdio>
#include <string>

#include "pof/core/offline.hpp"

namespace pof::cli {

inline const char* phase_name(pof::core::Direction d) {
  return d == pof::core::Direction::kFlexion ? "flexion" : d == pof::core::Direction::kExtension ? "extension" : "hold";
}

inline std::string compensation_csv(const Eigen::VectorXd& t_s, const Eigen::VectorXd& angle_ref_deg,
                                     const pof::core::OfflineResult& r) {
  std::string out = "t_s,angle_deg,angle_uncomp_deg,angle_ref_deg,velocity_rad_s,phase,quality\n";
  out.reserve(out.size() + static_cast<std::size_t>(t_s.size()) * 96);
  char buf[160];
  for (Eigen::Index i = 0; i < t_s.size(); ++i) {
    const double ref = angle_ref_deg.size() == t_s.size() ? angle_ref_deg(i) : std::nan("");
    // %.17g: the angles read back to the very double the compensator produced, so a file can be
    // compared bit for bit with the daemon's POF_ANGLE (float) stream (tests/e2e/compensatord_replay.sh).
    std::snprintf(buf, sizeof buf, "%.6f,%.17g,%.17g,%.9g,%.9g,%s,%d\n", t_s(i), r.angle_deg(i), r.angle_uncomp_deg(i), ref,
                  r.velocity_rad_s(i), phase_name(r.phase[static_cast<std::size_t>(i)]),
                  static_cast<int>(r.quality[static_cast<std::size_t>(i)]));
    out += buf;
  }
  return out;
}

}  // namespace pof::cli
