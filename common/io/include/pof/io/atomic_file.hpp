#pragma once
// Write-then-rename: a new file is written under a temporary name in the destination directory and
// renamed over the destination only by commit(), so an interrupted or failed run never leaves a
// half-written recording where a good one was (brief: "never overwrite good data with bad").
#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace pof::io {

/// Whether commit() may replace an existing destination.
enum class Replace { kYes, kNo };

class AtomicFile {
 public:
  /// Reserves a unique temporary file next to `dest`, created empty (mkstemp: 0600) and given
  /// `permissions` after the umask before anything is written, so a 0600 secret is never readable
  /// by others. Throws IoError naming the directory if it cannot. A `dest` that exists and is not a
  /// regular file (/dev/null, a FIFO) is written in place: temp_path() is `dest` itself and
  /// commit() does nothing; a directory, or any existing one with Replace::kNo, is an IoError.
  explicit AtomicFile(std::filesystem::path dest, mode_t permissions = 0666, Replace replace = Replace::kYes);
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  /// Removes the temporary file unless committed.
  ~AtomicFile();

  [[nodiscard]] const std::filesystem::path& temp_path() const { return tmp_; }
  [[nodiscard]] const std::filesystem::path& dest_path() const { return dest_; }
  /// fsyncs the (closed) temporary file and renames it onto the destination (Replace::kNo: links
  /// it there, which fails when the destination exists, even one created meanwhile). Throws IoError.
  void commit();

 private:
  std::filesystem::path dest_, tmp_;
  Replace replace_;
  bool committed_ = false;
  bool in_place_ = false;  // dest is a device or a pipe (see the constructor)
};

/// Writes `content` to `path` through an AtomicFile: the old file or the new one, never half.
/// Throws IoError (74) naming the path on any failure (Replace::kNo: also when it exists); the
/// temporary file is removed.
void write_file_atomic(const std::filesystem::path& path, const std::string& content, mode_t permissions = 0666,
                       Replace replace = Replace::kYes);

/// Where a command's output option points: "-" is standard output (an error writing it is an
/// IoError naming "standard output"), anything else write_file_atomic().
void write_output(const std::filesystem::path& path, const std::string& content);

/// A file a command reads or writes, with the option (or argument) that named it, for messages.
struct NamedPath {
  std::string option;  // e.g. "-o", "--csv", "recording"
  std::filesystem::path path;
};

/// Refuses, before anything is read, a command line whose output would replace one of its inputs
/// or another of its outputs: a write-then-rename onto the input recording succeeds and leaves the
/// result where the data was. Files are the same when stat(2) gives the same st_dev and st_ino
/// (so also through a symlink, a hard link or another spelling such as ./run.csv); an output that
/// does not exist yet is compared by its absolute, normalised path. "" (option not given) and "-"
/// (standard output) are skipped, and two outputs may share a character device (/dev/null). Throws
/// UsageError (exit 2) naming both options and the file.
void refuse_output_over_input(const std::vector<NamedPath>& inputs, const std::vector<NamedPath>& outputs);

}  // namespace pof::io
