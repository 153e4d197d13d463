#pragma once
// Recording readers. Formats (brief, "CSV everywhere data is read"; lcmtypes/raw_block_t.lcm):
//  - CSV with a header naming t_s, sensor_v, reference_v and angle_ref_deg or pot_v (both allowed);
//    angle_true_deg is read when present; other columns are ignored; '#' lines and blank lines are
//    skipped; "nan" is accepted in value columns (a dropout the compensator flags), not in t_s.
//    A line longer than kMaxCsvLineBytes is an error, so a file without newlines (or /dev/zero)
//    is refused after 64 KiB instead of being read into one string.
//  - LCM log (lcm-logger / lcm::LogFile) of pof.raw_block_t on POF_RAW or POF_RAW_<SENSOR_ID>,
//    channels mapped by name: "sensor", "reference", "pot", "angle_ref", "angle_true"; scanned by
//    LcmLogReader (lcmlog_scan.hpp), which bounds every length by the file.
// Errors (setup time, never on a streaming path): a missing or unreadable file is NoInputError
// (66); malformed content is DataError (65) naming file and line (CSV) or byte offset and event
// (LCM log), and the column or channel. A damaged LCM log is refused whole: the error names the
// byte offset of the first damage and counts the damaged regions, the events lost in them and the
// events that do not decode (LcmLogReader::damage_report()); a recording with a hole in it would
// calibrate or score as if nothing were missing. Quoted input is at most ~40 bytes (excerpt()).
#include <cstddef>
#include <string>
#include <string_view>

#include "pof/io/recording.hpp"

namespace pof::io {

class LcmLogReader;

/// Longest CSV line accepted (the widest real row is ~150 bytes).
inline constexpr std::size_t kMaxCsvLineBytes = 64 * 1024;

/// Reads a CSV recording. Throws NoInputError, DataError.
Recording read_csv(const std::string& path);
/// The same, from text in memory; `name` is used in messages (the fuzz target's entry).
Recording parse_csv(std::string_view text, const std::string& name);

/// Reads the raw blocks of one POF_RAW* channel of an LCM log. channel "" takes the first channel
/// named POF_RAW or POF_RAW_*. t_s counts from the first scan (utime of the first block).
/// Throws NoInputError, DataError.
Recording read_lcmlog(const std::string& path, const std::string& channel = "");
/// The same, from an opened log.
Recording read_lcmlog(LcmLogReader& log, const std::string& channel = "");

/// LCM log when the file starts with the LCM event sync word 0xEDA1DA01, CSV otherwise. Works on
/// pipes too: the sniffed bytes are not lost.
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
