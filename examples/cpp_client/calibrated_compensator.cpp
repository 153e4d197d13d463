// pof-calibrated-compensator: the compensator inside a controller, from the calibration file that
// `pof calibrate` wrote (pofkit::io loads it, pofkit::core compensates), for a controller that
// reads the DAQ itself and wants no bus hop. The calibration is loaded and checked exactly as
// pof-compensatord does it (the active model, its [gap] terms at this scan rate; anything invalid
// throws pof::ConfigError naming the key), so the angles are the daemon's.
//
//   pof-calibrated-compensator CAL.toml RECORDING.csv [OUT.csv]
//
// RECORDING.csv: t_s,sensor_v,reference_v,... (`pof sim`, or your own DAQ's volts); OUT.csv gets
// t_s,angle_deg,quality per scan (%.17g: comparable bit for bit with `pof compensate --csv`).
// Exit codes as pofkit's own: 0, 2 usage, 66 missing input, 78 bad calibration.
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "pof/base/errors.hpp"
#include "pof/core/compensator.hpp"
#include "pof/io/calibration_file.hpp"

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) {
    std::fprintf(stderr, "usage: %s CAL.toml RECORDING.csv [OUT.csv]\n", argv[0]);
    return pof::kExitUsage;
  }
  std::ifstream in(argv[2]);
  if (!in) {
    std::fprintf(stderr, "%s: cannot open\n", argv[2]);
    return pof::kExitNoInput;
  }
  std::vector<double> t, sensor_v, reference_v;
  std::string line;
  std::getline(in, line);  // the header: t_s,sensor_v,reference_v,...
  while (std::getline(in, line)) {
    double c[3];
    std::istringstream cells(line);
    std::string cell;
    for (double& v : c) {
      std::getline(cells, cell, ',');
      v = std::stod(cell);
    }
    t.push_back(c[0]);
    sensor_v.push_back(c[1]);
    reference_v.push_back(c[2]);
  }
  if (t.size() < 2) {
    std::fprintf(stderr, "%s: fewer than 2 scans\n", argv[2]);
    return pof::kExitDataErr;
  }
  const double rate_hz = double(t.size() - 1) / (t.back() - t.front());

  try {
    // The three lines: the calibration as pof-compensatord loads it ("file": its active model),
    // the settings at this DAQ's scan rate, the compensator.
    const pof::io::CalibrationFile file = pof::io::load_calibration(argv[1], "file", rate_hz);
    pof::core::CompensatorSettings settings;
    settings.scan_rate_hz = rate_hz;
    pof::core::OnlineCompensator comp(file.cal, settings);

    std::FILE* out = argc == 4 ? std::fopen(argv[3], "w") : nullptr;
    if (out != nullptr) std::fprintf(out, "t_s,angle_deg,quality\n");
    long flagged = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      const pof::core::CompensatedScan s = comp.step(sensor_v[i], reference_v[i]);  // one per scan
      flagged += s.quality != 0 ? 1 : 0;
      if (out != nullptr) std::fprintf(out, "%.6f,%.17g,%d\n", t[i], s.angle_deg, static_cast<int>(s.quality));
    }
    if (out != nullptr && std::fclose(out) != 0) return pof::kExitIoErr;
    std::printf("calibrated compensator: %s (sensor '%s', %s model): %zu scans at %.1f Hz, %ld flagged\n", argv[1],
                file.sensor_id.c_str(), pof::io::to_string(file.cal.active), t.size(), rate_hz, flagged);
  } catch (const pof::Error& e) {  // ConfigError (78) for a calibration that cannot be used, ...
    std::fprintf(stderr, "error: %s\n", e.what());
    return e.code();
  }
  return 0;
}
