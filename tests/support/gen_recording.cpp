// Test-data generator for the e2e scripts: writes a CSV recording made by paper_protocol.hpp.
//   gen_recording <out.csv> [calibration|validation] [angle_ref|pot]
// calibration: the paper's protocol (quasi-static steps + the nine table-1 velocities);
// validation: table 3's (10-80 deg, 3 cycles at 0.05, 0.10, 0.16, 0.21, 0.26 rad/s).
// The last column, angle_true_deg, is extra and must be ignored by the readers.
#include <cstdio>
#include <string>

#include "paper_protocol.hpp"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: gen_recording <out.csv> [calibration|validation] [angle_ref|pot]\n");
    return 2;
  }
  const std::string kind = argc > 2 ? argv[2] : "calibration";
  const bool pot = argc > 3 && std::string(argv[3]) == "pot";
  pof::testing::ProtocolSettings p;
  if (kind == "validation") {
    p.quasi_static = false;
    p.angle_lo = 10;
    p.angle_hi = 80;
    p.cycles_per_velocity = 3;
    p.velocities_rad_s = {0.05, 0.10, 0.16, 0.21, 0.26};
    p.seed = 2;
  }
  const auto g = pof::testing::paper_recording(p);
  std::FILE* f = std::fopen(argv[1], "w");
  if (!f) return 74;
  std::fprintf(f, "t_s,sensor_v,reference_v,%s,angle_true_deg\n", pot ? "pot_v" : "angle_ref_deg");
  for (Eigen::Index i = 0; i < g.size(); ++i)
    std::fprintf(f, "%.3f,%.5f,%.5f,%.5f,%.4f\n", g.t_s(i), g.sensor_v(i), g.reference_v(i),
                 pot ? g.pot_v(i) : g.angle_ref_deg(i), g.angle_true_deg(i));
  return std::fclose(f) == 0 ? 0 : 74;
}
