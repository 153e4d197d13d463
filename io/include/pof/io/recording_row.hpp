#pragma once
// One scan of a recording as the writers take it (the row of the CSV, one scan of a POF_RAW block).
#include <cstdint>

namespace pof::io {

struct RecordingRow {
  double t_s = 0;            // scan time from the start [s]
  double sensor_v = 0;       // sensor photodiode [V]
  double reference_v = 0;    // reference photodiode [V]
  double pot_v = 0;          // potentiometer [V]
  double angle_ref_deg = 0;  // reference angle after the potentiometer calibration [deg]
  double angle_true_deg = 0; // simulator ground truth [deg] (written only when enabled)
  bool over_range = false;   // a channel clipped at the input range (raw_block_t FLAG_OVER_RANGE)
};

}  // namespace pof::io
