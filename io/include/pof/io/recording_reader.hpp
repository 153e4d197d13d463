#pragma once
// Recording readers. Formats (brief, "CSV everywhere data is read"; lcmtypes/raw_block_t.lcm):
//  - CSV with a header naming t_s, sensor_v, reference_v and angle_ref_deg or pot_v (both allowed);
//    angle_true_deg is read when present; other columns are ignored; '#' lines and blank lines are
//    skipped; "nan" is accepted in value columns (a dropout the compensator flags), not in t_s.
//  - LCM log (lcm-logger / lcm::LogFile) of pof.raw_block_t on POF_RAW or POF_RAW_<SENSOR_ID>,
//    channels mapped by name: "sensor", "reference", "pot", "angle_ref", "angle_true".
// Errors (setup time, never on a streaming path): a missing or unreadable file is NoInputError
// (66); malformed content is DataError (65) naming file and line (CSV) or byte offset and event
// (LCM log), and the column or channel.
#include <string>

#include "pof/io/recording.hpp"

namespace pof::io {

/// Reads a CSV recording. Throws NoInputError, DataError.
Recording read_csv(const std::string& path);

/// Reads the raw blocks of one POF_RAW* channel of an LCM log. channel "" takes the first channel
/// named POF_RAW or POF_RAW_*. t_s counts from the first scan (utime of the first block).
/// Throws NoInputError, DataError.
Recording read_lcmlog(const std::string& path, const std::string& channel = "");

/// LCM log when the file starts with the LCM event sync word 0xEDA1DA01, CSV otherwise.
Recording read_recording(const std::string& path, const std::string& lcm_channel = "");


}  // namespace pof::io

#include "pof/core/potentiometer.hpp"

namespace pof::io {

/// The reference angle for the tools: pot_v through `pot` when a potentiometer calibration is
/// given and pot_v was recorded, else the recorded angle_ref_deg. Throws ConfigError when the
/// recording has pot_v only and no potentiometer calibration was given, DataError when it has
/// neither column.
Eigen::VectorXd reference_angle(const Recording& r, const pof::core::PotentiometerCalibration* pot);

}  // namespace pof::io
