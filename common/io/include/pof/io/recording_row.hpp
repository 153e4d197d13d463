#pragma once
// One scan of a recording as the writers take it (the row of the CSV, one scan of a POF_RAW block).
#include <cstdint>

#include "pof/io/recording.hpp"

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

/// Scan i of a recording as a row; a column the recording lacks (size != rec.size()) stays 0, and
/// the writers leave it out.
inline RecordingRow row_of(const Recording& rec, Eigen::Index i) {
  const Eigen::Index n = rec.size();
  RecordingRow r;
  r.t_s = rec.t_s[i];
  r.sensor_v = rec.sensor_v[i];
  r.reference_v = rec.reference_v[i];
  if (rec.pot_v.size() == n) r.pot_v = rec.pot_v[i];
  if (rec.angle_ref_deg.size() == n) r.angle_ref_deg = rec.angle_ref_deg[i];
  if (rec.angle_true_deg.size() == n) r.angle_true_deg = rec.angle_true_deg[i];
  return r;
}

}  // namespace pof::io
