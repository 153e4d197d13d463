#pragma once
// The report files of `pof gap` (gap.json, model.toml, series.csv, report.md). Recordings are read
// and written by pof_io (recording_reader.hpp, csv_writer.hpp). Every writer goes through a temp
// file and a rename (pof/io/atomic_file.hpp) so a failure never leaves a half-written report.
#include <filesystem>
#include <string>

#include "pof/gap/gap.hpp"
#include "pof/io/recording.hpp"

namespace pof::gap {

/// Writes gap.json, model.toml, series.csv and report.md into dir (created if missing); for a
/// checkpoint's result (not complete) everything but model.toml.
void write_outputs(const Result& r, const std::string& source, const std::filesystem::path& dir);

}  // namespace pof::gap
