#pragma once
// A recording in memory: one row per scan, columns as in the CSV format every tool accepts
// (t_s,sensor_v,reference_v,angle_ref_deg | pot_v). Produced by the readers (CSV, LCM log) and the
// simulator; consumed by calibration, compensation and `pof gap`.
#include <string>

#include <Eigen/Core>

namespace pof::io {

struct Recording {
  std::string source;            // file the data came from (for messages and the calibration file)
  Eigen::VectorXd t_s;           // scan time [s] from the start of the recording
  Eigen::VectorXd sensor_v;      // sensor photodiode [V]
  Eigen::VectorXd reference_v;   // reference photodiode [V]
  Eigen::VectorXd angle_ref_deg; // reference (potentiometer) angle [deg]; empty if only pot_v given
  Eigen::VectorXd pot_v;         // potentiometer [V]; empty if angle_ref_deg given
  Eigen::VectorXd angle_true_deg;// simulator ground truth [deg]; empty for measured data

  [[nodiscard]] Eigen::Index size() const { return t_s.size(); }
};

}  // namespace pof::io
