#pragma once
// CSV recordings: header `t_s,sensor_v,reference_v,angle_ref_deg[,pot_v][,angle_true_deg]`, one
// row per scan. Numbers are written in the shortest form that reads back to the same double
// (std::to_chars), so write -> read is exact. Written atomically (atomic_file.hpp).
#include <cstdio>
#include <filesystem>
#include <memory>

#include "pof/io/atomic_file.hpp"
#include "pof/io/recording.hpp"
#include "pof/io/recording_row.hpp"

namespace pof::io {

struct CsvColumns {
  bool angle_ref_deg = true;   // at least one of angle_ref_deg / pot_v must be written
  bool pot_v = false;
  bool angle_true_deg = true;  // simulator ground truth (readers ignore extra columns)
};

class CsvWriter {
 public:
  /// Throws IoError (cannot create the temporary file) or std::invalid_argument (no angle column).
  explicit CsvWriter(const std::filesystem::path& path, CsvColumns columns = {});
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;
  /// Discards the output unless commit() was called.
  ~CsvWriter();

  /// Appends a row (buffered). Throws IoError on a write error (disk full...).
  void write(const RecordingRow& row);
  /// Flushes, closes and renames onto the destination. Throws IoError.
  void commit();
  [[nodiscard]] std::size_t rows() const { return rows_; }

 private:
  void put(double v, bool last);
  AtomicFile file_;
  CsvColumns cols_;
  std::FILE* f_ = nullptr;
  std::size_t rows_ = 0;
};

/// The whole recording, with the columns it has (angle_ref_deg and/or pot_v, angle_true_deg).
void write_csv(const std::filesystem::path& path, const Recording& rec);

}  // namespace pof::io
