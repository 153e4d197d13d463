#pragma once
// Crash-safe writing, checking and repair of standard LCM log files (the format lcm-logplayer and
// lcm_eventlog_* read, described with the one reader every tool scans logs with in
// pof/io/lcmlog_scan.hpp).
//
// Durability model (why the writer looks like this): a file is only ever extended by whole events.
// Events are encoded in user space and handed to write(2) as complete batches; a short or failed
// write (ENOSPC, EFBIG, EIO) is undone with ftruncate(2) back to the end of the last complete
// event, so disk full never leaves a partial event behind. fdatasync(2) runs periodically, so after
// a power loss at most the last sync interval is lost, and what the kernel did not persist shows up
// as a torn tail (a partial event or zero blocks) that check_log() finds and repair_log() removes.
//
// Thread safety: a DurableLogWriter belongs to one thread. check_log()/repair_log() are free
// functions for files nobody is writing.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pof/io/lcmlog_scan.hpp"

namespace pof::recorder {

inline constexpr uint32_t kLogSync = io::kLcmLogSync;
inline constexpr std::size_t kLogHeaderBytes = io::kLcmLogHeaderBytes;
inline constexpr uint32_t kMaxChannelBytes = io::kLcmLogMaxChannelBytes;
inline constexpr uint32_t kMaxDataBytes = io::kLcmLogMaxDataBytes;
using io::get_be32;
using io::get_be64;
using io::put_be32;
using io::put_be64;

/// Result of a streaming-path write. Never thrown; the caller decides and reports.
enum class WriteStatus { kOk, kNoSpace, kIoError };

/// Appends whole LCM events to one file, crash-safely (see the file comment).
class DurableLogWriter {
 public:
  struct Options {
    std::size_t buffer_bytes = 1u << 20;  // events are batched up to this size before write(2)
  };

  /// Creates `path` (must not exist: never overwrites a recording). Throws pof::IoError naming
  /// the file when it cannot be created.
  DurableLogWriter(std::filesystem::path path, Options options);
  explicit DurableLogWriter(std::filesystem::path path) : DurableLogWriter(std::move(path), Options{}) {}
  ~DurableLogWriter();
  DurableLogWriter(const DurableLogWriter&) = delete;
  DurableLogWriter& operator=(const DurableLogWriter&) = delete;

  /// Encodes one event into the batch buffer; writes the batch when it is full. After a failure
  /// every further call returns the same failure and writes nothing.
  WriteStatus append(int64_t utime, std::string_view channel, const void* data, std::size_t size);
  /// Writes the batch buffer (whole events only).
  WriteStatus flush();
  /// flush() + fdatasync(2).
  WriteStatus sync();
  /// sync() and close. Idempotent.
  WriteStatus close();

  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  /// Events and bytes that reached the file (written, not necessarily synced).
  [[nodiscard]] uint64_t events_written() const { return events_written_; }
  [[nodiscard]] uint64_t bytes_written() const { return committed_; }
  /// Events accepted by append() (written or still in the batch buffer).
  [[nodiscard]] uint64_t events_appended() const { return next_event_; }
  /// errno of the first failure (0 when none).
  [[nodiscard]] int error_errno() const { return errno_; }
  [[nodiscard]] WriteStatus status() const { return status_; }

 private:
  WriteStatus fail(int err);

  std::filesystem::path path_;
  Options options_;
  int fd_ = -1;
  std::vector<unsigned char> buf_;
  uint64_t buffered_events_ = 0;
  uint64_t next_event_ = 0;
  uint64_t events_written_ = 0;
  uint64_t committed_ = 0;  // file offset just after the last complete event on disk
  WriteStatus status_ = WriteStatus::kOk;
  int errno_ = 0;
};

/// One complete event as found in a file.
struct LogEvent {
  uint64_t offset = 0;
  int64_t event_number = 0;
  int64_t utime = 0;
  std::string channel;
  std::vector<unsigned char> data;
};

/// What check_log() found.
struct LogCheck {
  uint64_t file_bytes = 0;
  uint64_t events = 0;          // complete events before the first bad byte
  uint64_t good_bytes = 0;      // offset just after the last complete event before the first bad byte
  std::string problem;          // why the byte at good_bytes is not a complete event ("" when clean)
  // Complete events found by resynchronising on the sync word after the first bad byte. Non-zero
  // means damage in the middle, not just a torn tail.
  uint64_t events_after_damage = 0;
  uint64_t bytes_after_damage = 0;  // bytes of those events
  uint64_t damaged_bytes = 0;       // bytes in no complete event (io::LcmLogScan)
  uint64_t damaged_regions = 0;
  uint64_t lost_events = 0;         // at least this many events lost in the damaged regions
  int64_t first_utime = 0;
  int64_t last_utime = 0;
  std::map<std::string, uint64_t> channel_events;  // of the complete events before the damage

  [[nodiscard]] bool clean() const { return good_bytes == file_bytes; }
  [[nodiscard]] uint64_t torn_bytes() const { return file_bytes - good_bytes; }
};

/// A complete event inside the scanned file; pointers valid only during the callback.
using LogEventRef = io::LcmEventRef;

/// Reads a log (io::LcmLogReader) and calls `on_event` for every complete event before the first
/// damage. Throws pof::NoInputError when the file cannot be opened.
LogCheck scan_log(const std::filesystem::path& path, const std::function<void(const LogEventRef&)>& on_event);
LogCheck check_log(const std::filesystem::path& path);
/// check_log() + the events themselves (for tests and small files).
std::vector<LogEvent> read_log(const std::filesystem::path& path, LogCheck* check = nullptr);

/// True while a DurableLogWriter holds the file open (advisory flock).
bool log_is_being_written(const std::filesystem::path& path);

struct RepairResult {
  LogCheck before;
  bool changed = false;
  std::filesystem::path backup;  // where the removed bytes or the original file were kept
  uint64_t events_kept = 0;
  std::string action;            // what was done, one line
};

/// Makes `path` a clean log, losing no complete event:
///  - torn tail only: the tail bytes are copied to `<path>.torn-<offset>` (fsync'd) and the file is
///    truncated to the last complete event (fsync'd);
///  - damage in the middle: every complete event (including those found after the damage) is
///    rewritten to a temporary file that is fsync'd and renamed over `path`; the original is kept
///    as `<path>.bak`.
/// A clean file is left untouched. Throws pof::NoInputError / IoError naming the file.
RepairResult repair_log(const std::filesystem::path& path);

}  // namespace pof::recorder
