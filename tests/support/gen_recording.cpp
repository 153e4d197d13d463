// Test-data generator for the e2e scripts: writes a CSV recording made by paper_protocol.hpp.
//   gen_recording <out.csv|out.lcmlog> [calibration|validation] [angle_ref|pot]
// calibration: the paper's protocol (quasi-static steps + the nine table-1 velocities);
// validation: table 3's (10-80 deg, 3 cycles at 0.05, 0.10, 0.16, 0.21, 0.26 rad/s).
// The last column, angle_true_deg, is extra and must be ignored by the readers. A name ending in
// .lcmlog gives an LCM log of pof.raw_block_t on POF_RAW (20 scans a block, channels by name).
#include <cstdio>
#include <string>

#include <lcm/lcm-cpp.hpp>
#include <pof/raw_block_t.hpp>

#include "pof/testing/paper_protocol.hpp"

namespace {

int write_lcmlog(const std::string& path, const pof::testing::Generated& g, bool pot) {
  lcm::LogFile log(path, "w");
  if (!log.good()) return 74;
  const int per_block = 20;
  const std::int64_t t0 = 1'763'700'000'000'000;
  for (Eigen::Index first = 0, seq = 0; first < g.size(); first += per_block, ++seq) {
    pof::raw_block_t b{};
    b.utime = t0 + static_cast<std::int64_t>(std::llround(g.t_s(first) * 1e6));
    b.publish_utime = b.utime + 100'000;
    b.seq = seq;
    b.first_scan = first;
    b.scan_rate_hz = 200;
    b.sensor_id = "";
    b.channel_names = {"sensor", "reference", pot ? "pot" : "angle_ref", "angle_true"};
    b.channel_units = {"V", "V", pot ? "V" : "deg", "deg"};
    b.n_channels = 4;
    b.n_scans = static_cast<std::int32_t>(std::min<Eigen::Index>(per_block, g.size() - first));
    for (Eigen::Index i = first; i < first + b.n_scans; ++i)
      b.volts.push_back({static_cast<float>(g.sensor_v(i)), static_cast<float>(g.reference_v(i)),
                         static_cast<float>(pot ? g.pot_v(i) : g.angle_ref_deg(i)), static_cast<float>(g.angle_true_deg(i))});
    b.flags = pof::raw_block_t::FLAG_SIMULATED;
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(b.getEncodedSize()));
    b.encode(buf.data(), 0, static_cast<int>(buf.size()));
    lcm::LogEvent ev{};
    ev.timestamp = b.publish_utime;
    ev.channel = "POF_RAW";
    ev.datalen = static_cast<std::int32_t>(buf.size());
    ev.data = buf.data();
    if (log.writeEvent(&ev) != 0) return 74;
  }
  return 0;
}

}  // namespace

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
    p.velocities_rad_s = {pof::core::kTable3Velocities.begin(), pof::core::kTable3Velocities.end()};
    p.seed = 2;
  }
  const auto g = pof::testing::paper_recording(p);
  const std::string out = argv[1];
  if (out.size() > 7 && out.substr(out.size() - 7) == ".lcmlog") return write_lcmlog(out, g, pot);
  std::FILE* f = std::fopen(argv[1], "w");
  if (!f) return 74;
  std::fprintf(f, "t_s,sensor_v,reference_v,%s,angle_true_deg\n", pot ? "pot_v" : "angle_ref_deg");
  for (Eigen::Index i = 0; i < g.size(); ++i)
    std::fprintf(f, "%.3f,%.5f,%.5f,%.5f,%.4f\n", g.t_s(i), g.sensor_v(i), g.reference_v(i),
                 pot ? g.pot_v(i) : g.angle_ref_deg(i), g.angle_true_deg(i));
  return std::fclose(f) == 0 ? 0 : 74;
}
