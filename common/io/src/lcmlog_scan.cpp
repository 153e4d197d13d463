// The LCM log scanner (format, damage model and why not liblcm's reader: lcmlog_scan.hpp).
#include "pof/io/lcmlog_scan.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <utility>

#include "pof/base/errors.hpp"
#include "pof/bus/auth_trailer.hpp"

namespace pof::io {
namespace {

// First offset in [from, limit) that holds a plausible event header, or size when none. memchr
// finds the sync word's first byte, so skipping a large damaged region costs a pass over it, not a
// header parse per byte.
std::uint64_t resync(const unsigned char* d, std::uint64_t from, std::uint64_t size, std::uint64_t limit) {
  if (size < kLcmLogHeaderBytes) return size;
  limit = std::min(limit, size - kLcmLogHeaderBytes + 1);
  std::uint64_t off = from;
  while (off < limit) {
    const void* hit = std::memchr(d + off, 0xED, static_cast<std::size_t>(limit - off));
    if (hit == nullptr) break;
    off = static_cast<std::uint64_t>(static_cast<const unsigned char*>(hit) - d);
    std::uint32_t cl = 0;
    std::uint32_t dl = 0;
    if (get_be32(d + off) == kLcmLogSync && !lcm_header_problem(d + off, off, size, &cl, &dl)) return off;
    ++off;
  }
  return size;
}

std::string plural(std::uint64_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

}  // namespace

std::optional<std::string> lcm_header_problem(const unsigned char* p, std::uint64_t offset, std::uint64_t file_bytes,
                                              std::uint32_t* channel_len, std::uint32_t* data_len) {
  const std::uint32_t sync = get_be32(p);
  if (sync != kLcmLogSync) {
    char b[64];
    std::snprintf(b, sizeof b, "bad sync word 0x%08X (expected 0xEDA1DA01)", sync);
    return std::string(b);
  }
  *channel_len = get_be32(p + 20);
  *data_len = get_be32(p + 24);
  if (*channel_len == 0 || *channel_len > kLcmLogMaxChannelBytes)
    return "implausible channel length " + std::to_string(static_cast<std::int32_t>(*channel_len)) + " (expected 1..63)";
  if (*data_len > kLcmLogMaxDataBytes)
    return "implausible data length " + std::to_string(static_cast<std::int32_t>(*data_len));
  const std::uint64_t need = kLcmLogHeaderBytes + std::uint64_t{*channel_len} + *data_len;
  if (need > file_bytes - offset)
    return "event truncated: needs " + std::to_string(need) + " bytes, " + std::to_string(file_bytes - offset) + " left";
  return std::nullopt;
}

LcmLogScan scan_lcmlog(std::span<const unsigned char> bytes, const std::function<void(const LcmEventRef&)>& on_event) {
  LcmLogScan s;
  const unsigned char* d = bytes.data();
  const std::uint64_t size = bytes.size();
  s.file_bytes = size;
  s.first_damage = size;
  std::uint64_t off = 0;
  bool damaged = false;
  bool have_prev = false;
  std::int64_t prev_number = 0;
  // Event numbers lost in the current damaged region are known once the next event is accepted.
  std::uint64_t region_bytes = 0;
  auto close_region = [&](const std::int64_t* next_number) {
    // The gap in event numbers across the region, when the numbers can be believed: each lost event
    // took at least a header and a one-byte channel, so a gap the region cannot hold (or a number
    // going backwards) means the numbers are damaged too, and so does a region with no event after
    // it (a torn tail): then one event is counted, the least that explains the region.
    std::uint64_t lost = 1;
    std::int64_t expected = 0;  // event numbers are any int64 in a damaged file
    const bool overflow = have_prev && __builtin_add_overflow(prev_number, 1, &expected);
    if (next_number != nullptr && !overflow && *next_number >= expected) {
      const std::uint64_t gap = static_cast<std::uint64_t>(*next_number) - static_cast<std::uint64_t>(expected);
      if (gap <= region_bytes / (kLcmLogHeaderBytes + 1)) lost = gap;
    }
    s.lost_events += lost;
    region_bytes = 0;
  };
  auto damage = [&](std::uint64_t at, std::uint64_t next, std::string why) {
    if (!damaged) {
      damaged = true;
      s.first_damage = at;
      s.problem = std::move(why);
    }
    if (region_bytes == 0) ++s.damaged_regions;
    region_bytes += next - at;
    s.damaged_bytes += next - at;
  };
  auto deliver = [&](const LcmEventRef& ev) {
    if (region_bytes > 0) close_region(&ev.event_number);
    have_prev = true;
    prev_number = ev.event_number;
    ++s.events;
    if (!damaged) ++s.events_before_damage;
    else s.bytes_after_damage += ev.end() - ev.offset;
    if (on_event) on_event(ev);
  };
  // An event is handed on only once the bytes after it are known to start another event (or end
  // the file): a flipped bit that makes a data length larger still fits the file, and the event
  // would swallow the events after it. When damage follows an event and a plausible header lies
  // inside that event's data, it is the event's length that is wrong: the event is damage, and
  // the scan carries on at the header found inside it.
  std::optional<LcmEventRef> pending;
  while (off < size) {
    std::uint32_t cl = 0;
    std::uint32_t dl = 0;
    std::optional<std::string> why;
    if (size - off < kLcmLogHeaderBytes) why = "partial header: " + std::to_string(size - off) + " bytes";
    else why = lcm_header_problem(d + off, off, size, &cl, &dl);
    if (why) {
      if (pending) {
        const LcmEventRef prev = *pending;
        pending.reset();
        const std::uint64_t inside = resync(d, static_cast<std::uint64_t>(prev.data - d), size, off);
        if (inside < off) {
          damage(prev.offset, inside,
                 "event " + std::to_string(prev.event_number) + " claims " + std::to_string(prev.data_size) +
                     " data bytes but an event header starts inside them at byte " + std::to_string(inside) +
                     " (the bytes after it: " + *why + ")");
          off = inside;
          continue;
        }
        deliver(prev);
      }
      const std::uint64_t next = resync(d, off + 1, size, size);
      damage(off, next, std::move(*why));
      off = next;
      continue;
    }
    LcmEventRef ev;
    ev.offset = off;
    ev.event_number = static_cast<std::int64_t>(get_be64(d + off + 4));
    ev.utime = static_cast<std::int64_t>(get_be64(d + off + 12));
    ev.channel = std::string_view(reinterpret_cast<const char*>(d + off + kLcmLogHeaderBytes), cl);
    ev.data = d + off + kLcmLogHeaderBytes + cl;
    ev.data_size = dl;
    if (pending) deliver(*pending);
    ev.after_damage = damaged;
    pending = ev;
    off = ev.end();
  }
  if (pending) deliver(*pending);
  if (region_bytes > 0) close_region(nullptr);
  return s;
}

// ---------------------------------------------------------------------------------------------
LcmLogReader::LcmLogReader(std::string path, std::uint64_t max_stream_bytes) : path_(std::move(path)) {
  const int fd = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw NoInputError(path_ + ": cannot open: " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw NoInputError(path_ + ": cannot stat: " + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) throw NoInputError(path_ + ": is a directory, expected an LCM log file");
  if (S_ISREG(st.st_mode)) {
    size_ = static_cast<std::uint64_t>(st.st_size);
    if (size_ > 0) {
      void* m = ::mmap(nullptr, static_cast<std::size_t>(size_), PROT_READ, MAP_PRIVATE, fd, 0);
      if (m == MAP_FAILED) throw NoInputError(path_ + ": cannot map: " + std::strerror(errno));
      map_ = m;
      data_ = static_cast<const unsigned char*>(m);
      ::madvise(m, static_cast<std::size_t>(size_), MADV_SEQUENTIAL);
    }
    return;
  }
  read_stream(fd, S_ISCHR(st.st_mode), max_stream_bytes);
}

LcmLogReader::LcmLogReader(std::string name, int stream_fd, std::vector<unsigned char> head, std::uint64_t max_stream_bytes)
    : path_(std::move(name)), owned_(std::move(head)) {
  read_stream(stream_fd, false, max_stream_bytes);
}

void LcmLogReader::read_stream(int fd, bool device, std::uint64_t max_bytes) {
  // Appends up to `want` bytes; true when all came.
  auto read_some = [&](std::size_t want) {
    const std::size_t at = owned_.size();
    owned_.resize(at + want);
    std::size_t got = 0;
    while (got < want) {
      const ssize_t r = ::read(fd, owned_.data() + at + got, want - got);
      if (r < 0 && errno == EINTR) continue;
      if (r < 0) throw IoError(path_ + ": read error after " + std::to_string(at + got) + " bytes: " + std::strerror(errno));
      if (r == 0) break;
      got += static_cast<std::size_t>(r);
    }
    owned_.resize(at + got);
    return got == want;
  };
  const std::string too_long =
      path_ + ": not a regular file and longer than " + std::to_string(max_bytes >> 20) + " MiB: copy it to a file first";
  if (owned_.size() >= kLcmLogHeaderBytes || read_some(kLcmLogHeaderBytes - owned_.size())) {
    // No size to check lengths against: the first header must be plausible on its own.
    std::uint32_t cl = 0;
    std::uint32_t dl = 0;
    if (auto why = lcm_header_problem(owned_.data(), 0, max_bytes, &cl, &dl))
      throw DataError(path_ + ": byte 0: not an LCM log (" + *why + "); stopped reading this " +
                      (device ? "device" : "stream") + " after " + std::to_string(owned_.size()) + " bytes");
    while (owned_.size() <= max_bytes && read_some(1u << 20)) {
    }
    if (owned_.size() > max_bytes) throw DataError(too_long);
  }
  data_ = owned_.data();
  size_ = owned_.size();
}

LcmLogReader::LcmLogReader(std::string name, std::vector<unsigned char> bytes)
    : path_(std::move(name)), owned_(std::move(bytes)) {
  data_ = owned_.data();
  size_ = owned_.size();
}

LcmLogReader::~LcmLogReader() {
  if (map_ != nullptr) ::munmap(map_, static_cast<std::size_t>(size_));
}

const LcmLogScan& LcmLogReader::scan(const std::function<void(const LcmEventRef&)>& on_event) {
  scan_ = scan_lcmlog(bytes(), on_event);
  return scan_;
}

void LcmLogReader::undecodable(const LcmEventRef& ev, const std::string& why) {
  if (undecodable_++ == 0) {
    first_undecodable_offset_ = ev.offset;
    first_undecodable_why_ = "event " + std::to_string(ev.event_number) + " on channel " + excerpt(ev.channel) + ": " + why;
    // A log of the authenticated mode's signed messages as they were on the bus (lcm-logger's, or
    // `pof record` without the key): say so, not only "bytes after the last field".
    if (bus::auth::parse_trailer(ev.data, ev.data_size))
      first_undecodable_why_ += " (the message ends in an authenticated-mode trailer: a log of signed messages as "
                                "they were on the bus; `pof record --auth-key-file` records them verified and "
                                "without trailers, docs/deployment.md)";
  }
}

std::string LcmLogReader::damage_report() const {
  const LcmLogScan& s = scan_;
  std::string first;
  if (!s.clean() && (undecodable_ == 0 || s.first_damage <= first_undecodable_offset_))
    first = "byte " + std::to_string(s.first_damage) + ": " + s.problem;
  else if (undecodable_ > 0)
    first = "byte " + std::to_string(first_undecodable_offset_) + ": " + first_undecodable_why_;
  std::string r = path_ + ": damaged LCM log: first damage at " + first + "; ";
  if (s.clean()) r += "no damaged framing";
  else
    r += plural(s.damaged_regions, "damaged region", "damaged regions") + " (" +
         plural(s.damaged_bytes, "byte", "bytes") + ") skipped, at least " +
         plural(s.lost_events, "event", "events") + " lost";
  r += "; " + plural(undecodable_, "event", "events") + " not decodable; " + std::to_string(s.events) +
       " complete events read";
  return r;
}

}  // namespace pof::io
