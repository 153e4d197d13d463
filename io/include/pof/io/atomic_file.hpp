#pragma once
// Write-then-rename: a new file is written under a temporary name in the destination directory and
// renamed over the destination only by commit(), so an interrupted or failed run never leaves a
// half-written recording where a good one was (brief: "never overwrite good data with bad").
#include <filesystem>
#include <string>

namespace pof::io {

class AtomicFile {
 public:
  /// Reserves a unique temporary file next to `dest` (created empty, mode 0644 after umask).
  /// Throws IoError naming the directory if it cannot.
  explicit AtomicFile(std::filesystem::path dest);
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  /// Removes the temporary file unless committed.
  ~AtomicFile();

  [[nodiscard]] const std::filesystem::path& temp_path() const { return tmp_; }
  [[nodiscard]] const std::filesystem::path& dest_path() const { return dest_; }
  /// fsyncs the (closed) temporary file and renames it onto the destination. Throws IoError.
  void commit();

 private:
  std::filesystem::path dest_, tmp_;
  bool committed_ = false;
};

/// Writes `content` to `path` through an AtomicFile: the old file or the new one, never half.
/// Throws IoError (74) naming the path on any failure; the temporary file is removed.
void write_file_atomic(const std::filesystem::path& path, const std::string& content);

/// Where a command's output option points: "-" is standard output (an error writing it is an
/// IoError naming "standard output"), anything else write_file_atomic().
void write_output(const std::filesystem::path& path, const std::string& content);

}  // namespace pof::io
