// Crash-safe LCM log writing, checking and repair; the format and durability model are described in
// pof/recorder/lcmlog_durable.hpp.
#include "pof/recorder/lcmlog_durable.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "pof/base/errors.hpp"

namespace pof::recorder {
namespace {

std::string errstr(int err) { return std::strerror(err); }

// write(2) until done; returns 0 or the errno of the failure. A short write of a regular file means
// the device is full or the file size limit was reached; the next write() then reports why.
int write_all(int fd, const unsigned char* p, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    if (w == 0) return ENOSPC;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return 0;
}

int fsync_dir(const std::filesystem::path& dir) {
  const int dfd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0) return errno;
  const int rc = ::fsync(dfd) == 0 ? 0 : errno;
  ::close(dfd);
  return rc;
}

}  // namespace

// ----------------------------------------------------------------------------------------------
DurableLogWriter::DurableLogWriter(std::filesystem::path path, Options options)
    : path_(std::move(path)), options_(options) {
  // O_EXCL: a recorder never overwrites an earlier recording.
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd_ < 0) throw pof::IoError(path_.string() + ": cannot create the log file: " + errstr(errno));
  // Advisory lock for as long as we write: repair_log() refuses a file that is being recorded,
  // and check_log() says its tail may still be in flight.
  ::flock(fd_, LOCK_EX | LOCK_NB);
  // The directory entry must survive a power loss too, or the whole log vanishes.
  if (const int err = fsync_dir(path_.parent_path()); err != 0)
    throw pof::IoError(path_.parent_path().string() + ": cannot fsync the directory: " + errstr(err));
  buf_.reserve(options_.buffer_bytes + 4096);
}

DurableLogWriter::~DurableLogWriter() { close(); }

WriteStatus DurableLogWriter::fail(int err) {
  errno_ = err;
  status_ = (err == ENOSPC || err == EFBIG || err == EDQUOT) ? WriteStatus::kNoSpace : WriteStatus::kIoError;
  return status_;
}

WriteStatus DurableLogWriter::append(int64_t utime, std::string_view channel, const void* data, std::size_t size) {
  if (status_ != WriteStatus::kOk) return status_;
  if (fd_ < 0) return fail(EBADF);
  if (channel.empty() || channel.size() > kMaxChannelBytes || size > kMaxDataBytes) return fail(EINVAL);
  const std::size_t n = kLogHeaderBytes + channel.size() + size;
  if (!buf_.empty() && buf_.size() + n > options_.buffer_bytes) {
    if (flush() != WriteStatus::kOk) return status_;
  }
  const std::size_t at = buf_.size();
  buf_.resize(at + n);
  unsigned char* p = buf_.data() + at;
  put_be32(p, kLogSync);
  put_be64(p + 4, next_event_);
  put_be64(p + 12, static_cast<uint64_t>(utime));
  put_be32(p + 20, static_cast<uint32_t>(channel.size()));
  put_be32(p + 24, static_cast<uint32_t>(size));
  std::memcpy(p + kLogHeaderBytes, channel.data(), channel.size());
  if (size > 0) std::memcpy(p + kLogHeaderBytes + channel.size(), data, size);
  ++next_event_;
  ++buffered_events_;
  if (buf_.size() >= options_.buffer_bytes) return flush();
  return WriteStatus::kOk;
}

WriteStatus DurableLogWriter::flush() {
  if (status_ != WriteStatus::kOk) return status_;
  if (buf_.empty()) return WriteStatus::kOk;
  const int err = write_all(fd_, buf_.data(), buf_.size());
  if (err != 0) {
    // Undo the partial batch so the file ends on a complete event (disk full never corrupts
    // what was written). If even that fails the tail is torn; check/repair find it.
    while (::ftruncate(fd_, static_cast<off_t>(committed_)) != 0 && errno == EINTR) {
    }
    ::lseek(fd_, static_cast<off_t>(committed_), SEEK_SET);
    ::fdatasync(fd_);
    next_event_ -= buffered_events_;
    buffered_events_ = 0;
    buf_.clear();
    return fail(err);
  }
  committed_ += buf_.size();
  events_written_ += buffered_events_;
  buffered_events_ = 0;
  buf_.clear();
  return WriteStatus::kOk;
}

WriteStatus DurableLogWriter::sync() {
  if (flush() != WriteStatus::kOk) return status_;
  if (::fdatasync(fd_) != 0) return fail(errno);
  return WriteStatus::kOk;
}

WriteStatus DurableLogWriter::close() {
  if (fd_ < 0) return status_;
  if (status_ == WriteStatus::kOk) sync();
  ::close(fd_);
  fd_ = -1;
  return status_;
}

// ----------------------------------------------------------------------------------------------
LogCheck scan_log(const std::filesystem::path& path, const std::function<void(const LogEventRef&)>& on_event) {
  io::LcmLogReader log(path.string());
  LogCheck c;
  const io::LcmLogScan& s = log.scan([&](const LogEventRef& ev) {
    if (ev.after_damage) return;
    if (c.events == 0) c.first_utime = ev.utime;
    c.last_utime = ev.utime;
    ++c.channel_events[std::string(ev.channel)];
    ++c.events;
    if (on_event) on_event(ev);
  });
  c.file_bytes = s.file_bytes;
  c.good_bytes = s.first_damage;
  c.problem = s.problem;
  c.events_after_damage = s.events_after_damage();
  c.bytes_after_damage = s.bytes_after_damage;
  c.damaged_bytes = s.damaged_bytes;
  c.damaged_regions = s.damaged_regions;
  c.lost_events = s.lost_events;
  return c;
}

LogCheck check_log(const std::filesystem::path& path) { return scan_log(path, {}); }

std::vector<LogEvent> read_log(const std::filesystem::path& path, LogCheck* check) {
  std::vector<LogEvent> out;
  LogCheck c = scan_log(path, [&](const LogEventRef& e) {
    out.push_back(LogEvent{e.offset, e.event_number, e.utime, std::string(e.channel),
                           std::vector<unsigned char>(e.data, e.data + e.data_size)});
  });
  if (check != nullptr) *check = c;
  return out;
}

// ----------------------------------------------------------------------------------------------
namespace {

void write_file_synced(const std::filesystem::path& path, const unsigned char* p, std::size_t n) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw pof::IoError(path.string() + ": cannot create: " + errstr(errno));
  int err = write_all(fd, p, n);
  if (err == 0 && ::fsync(fd) != 0) err = errno;
  ::close(fd);
  if (err != 0) {
    ::unlink(path.c_str());
    throw pof::IoError(path.string() + ": cannot write: " + errstr(err));
  }
}

std::filesystem::path free_name(const std::filesystem::path& want) {
  std::filesystem::path p = want;
  for (int i = 1; std::filesystem::exists(p); ++i) p = want.string() + "." + std::to_string(i);
  return p;
}

}  // namespace

bool log_is_being_written(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool busy = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  return busy;
}

RepairResult repair_log(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw pof::NoInputError(path.string() + ": not a regular file: nothing to repair in place");
  if (log_is_being_written(path))
    throw pof::IoError(path.string() + ": a recorder is still writing this file (it holds its lock); stop it before --repair");
  RepairResult r;
  r.before = check_log(path);
  const LogCheck& c = r.before;
  r.events_kept = c.events;
  if (c.clean()) {
    r.action = "clean: " + std::to_string(c.events) + " complete events, nothing to repair";
    return r;
  }
  const std::filesystem::path dir = path.parent_path();
  if (c.events_after_damage == 0) {
    // Torn tail: keep the removed bytes (they may matter to someone), then truncate.
    r.backup = free_name(path.string() + ".torn-" + std::to_string(c.good_bytes));
    {
      const io::LcmLogReader f(path.string());
      write_file_synced(r.backup, f.bytes().data() + c.good_bytes, static_cast<std::size_t>(c.torn_bytes()));
    }
    const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd < 0) throw pof::IoError(path.string() + ": cannot open for repair: " + errstr(errno));
    int err = 0;
    if (::ftruncate(fd, static_cast<off_t>(c.good_bytes)) != 0) err = errno;
    if (err == 0 && ::fsync(fd) != 0) err = errno;
    ::close(fd);
    if (err != 0) throw pof::IoError(path.string() + ": cannot truncate: " + errstr(err));
    r.changed = true;
    r.action = "truncated a torn tail of " + std::to_string(c.torn_bytes()) + " bytes at offset " +
               std::to_string(c.good_bytes) + " (" + c.problem + "); kept " + std::to_string(c.events) +
               " complete events; removed bytes saved in " + r.backup.string();
    return r;
  }
  // Damage in the middle: rewrite every complete event into a new file, renumbered, then swap.
  const std::filesystem::path tmp = free_name(path.string() + ".repair-tmp");
  uint64_t kept = 0;
  {
    io::LcmLogReader f(path.string());
    DurableLogWriter w(tmp);
    f.scan([&](const LogEventRef& ev) {
      w.append(ev.utime, ev.channel, ev.data, ev.data_size);
      ++kept;
    });
    if (w.close() != WriteStatus::kOk) {
      const int err = w.error_errno();
      std::filesystem::remove(tmp);
      throw pof::IoError(tmp.string() + ": cannot write the repaired log: " + errstr(err));
    }
  }
  r.backup = free_name(path.string() + ".bak");
  if (::link(path.c_str(), r.backup.c_str()) != 0)
    throw pof::IoError(r.backup.string() + ": cannot keep the original: " + errstr(errno));
  if (::rename(tmp.c_str(), path.c_str()) != 0)
    throw pof::IoError(path.string() + ": cannot replace with the repaired log: " + errstr(errno));
  fsync_dir(dir);
  r.changed = true;
  r.events_kept = kept;
  r.action = "rewrote " + std::to_string(kept) + " complete events around damage at offset " +
             std::to_string(c.good_bytes) + " (" + c.problem + "); original kept as " + r.backup.string();
  return r;
}

}  // namespace pof::recorder
