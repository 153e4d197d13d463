#pragma once
// Files of `pof gap`: the recording CSV reader used until the shared io readers land, and the
// report writers (gap.json, model.toml, series.csv, report.md). Every writer goes through a temp
// file and a rename so a failure never leaves a half-written report over a good one.
#include <filesystem>
#include <string>

#include "pof/gap/gap.hpp"
#include "pof/io/recording.hpp"

namespace pof::gap {

/// Reads `t_s,sensor_v,reference_v,angle_ref_deg` (extra columns ignored; `angle_true_deg` kept).
/// Throws NoInputError (missing/unreadable) or DataError naming file, line and column.
io::Recording read_csv_recording(const std::filesystem::path& path);

/// Writes `t_s,sensor_v,reference_v,angle_ref_deg,angle_true_deg` (the simulator's CSV).
void write_csv_recording(const io::Recording& rec, const std::filesystem::path& path);

/// Writes gap.json, model.toml, series.csv and report.md into dir (created if missing).
void write_outputs(const Result& r, const std::string& source, const std::filesystem::path& dir);

/// Writes text to path atomically (temp file + rename); throws IoError naming the path.
void write_file_atomic(const std::filesystem::path& path, const std::string& text);

}  // namespace pof::gap
