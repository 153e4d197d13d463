#pragma once
// The one reader of LCM log files in pofkit: `pof calibrate/compensate/gap` (read_lcmlog),
// `pof export` and `pof record --check/--repair` all scan logs through it.
//
// Format (lcm/eventlog.c, lcm_eventlog_write_event; what lcm-logger and lcm-logplayer use): a log
// is a sequence of events with no file header, index or trailer. Each event is
//
//   offset 0   u32 sync word 0xEDA1DA01       all integers big-endian
//          4   i64 event number              0, 1, 2, ... within one file
//         12   i64 timestamp                 [us since the Unix epoch]
//         20   i32 channel length            1..63 (lcm.h: LCM_MAX_CHANNEL_NAME_LENGTH)
//         24   i32 data length               >= 0
//         28   channel bytes (no NUL), then data bytes (an LCM message: 8-byte fingerprint first)
//
// Why not liblcm's lcm_eventlog_read_next_event: it trusts the lengths. It callocs datalen + 1
// bytes, an int that overflows to INT_MIN for 0x7fffffff, so calloc fails and fread writes into
// NULL (a crash); a flipped high bit short of that allocates and zero-fills up to 2 GiB per event;
// and it returns NULL both at the end of the file and on a truncated or damaged event, silently
// skipping bytes to the next sync word in between.
//
// This reader never allocates from a length in the file. A regular file is mapped read-only; every
// length is checked against the bytes that remain before it is used. An event whose header is not
// plausible (wrong sync word, channel length outside 1..63, data running past the end) starts a
// damaged region; the scan resynchronises on the next plausible header and carries on, counting
// the damaged bytes, the regions and the events lost in them (from the gap in event numbers). A
// caller decides what damage means: the recording readers refuse a damaged log (exit 65), `pof
// export --salvage` keeps what is readable, `pof record --repair` rewrites around the damage.
//
// Input that is not a regular file (a pipe, a character device such as /dev/zero) cannot be
// mapped and has no size to check lengths against: it is read into memory, at most
// kLcmLogMaxStreamBytes, and must begin with a plausible event header, so an endless or foreign
// stream is refused after its first 28 bytes instead of filling memory.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "pof/lcm/decode.hpp"

namespace pof::io {

inline constexpr std::uint32_t kLcmLogSync = 0xEDA1DA01u;
inline constexpr std::size_t kLcmLogHeaderBytes = 28;
// lcm.h: LCM_MAX_CHANNEL_NAME_LENGTH is 63; liblcm refuses to publish longer names.
inline constexpr std::uint32_t kLcmLogMaxChannelBytes = 63;
// Sanity bound on one event's data, far above any LCM message (lcm_udpm fragments at most 64 KiB
// per datagram and the largest pofkit message is a raw block of a few KiB).
inline constexpr std::uint32_t kLcmLogMaxDataBytes = 1u << 30;
// Most bytes read from input that is not a regular file.
inline constexpr std::uint64_t kLcmLogMaxStreamBytes = 256ull << 20;

// Big-endian helpers (the log header and the LCM wire format).
inline void put_be32(unsigned char* p, std::uint32_t v) {
  p[0] = static_cast<unsigned char>(v >> 24);
  p[1] = static_cast<unsigned char>(v >> 16);
  p[2] = static_cast<unsigned char>(v >> 8);
  p[3] = static_cast<unsigned char>(v);
}
inline void put_be64(unsigned char* p, std::uint64_t v) {
  put_be32(p, static_cast<std::uint32_t>(v >> 32));
  put_be32(p + 4, static_cast<std::uint32_t>(v));
}
inline std::uint32_t get_be32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}
inline std::uint64_t get_be64(const unsigned char* p) {
  return (std::uint64_t{get_be32(p)} << 32) | std::uint64_t{get_be32(p + 4)};
}

/// One complete event inside the scanned bytes; the pointers are valid while the bytes are.
struct LcmEventRef {
  std::uint64_t offset = 0;  // of the sync word
  std::int64_t event_number = 0;
  std::int64_t utime = 0;
  std::string_view channel;
  const unsigned char* data = nullptr;
  std::uint32_t data_size = 0;
  bool after_damage = false;  // found by resynchronising after a damaged region

  [[nodiscard]] std::uint64_t end() const { return offset + kLcmLogHeaderBytes + channel.size() + data_size; }
};

/// What a scan found.
struct LcmLogScan {
  std::uint64_t file_bytes = 0;
  std::uint64_t events = 0;                // complete events, before and after any damage
  std::uint64_t events_before_damage = 0;  // complete events before the first damaged byte
  std::uint64_t first_damage = 0;          // offset of the first damaged byte (file_bytes when clean)
  std::string problem;                     // why that byte does not start an event ("" when clean)
  std::uint64_t damaged_bytes = 0;         // bytes in no complete event
  std::uint64_t damaged_regions = 0;       // runs of such bytes
  // Events lost in the damaged regions: the gap in event numbers across each region (0 for bytes
  // inserted between two consecutive events); one for a region with no event after it (a torn
  // tail) or whose neighbours' numbers do not fit in it.
  std::uint64_t lost_events = 0;
  std::uint64_t bytes_after_damage = 0;    // bytes of the complete events after the first damage

  [[nodiscard]] bool clean() const { return damaged_bytes == 0; }
  [[nodiscard]] std::uint64_t events_after_damage() const { return events - events_before_damage; }
};

/// Why the `kLcmLogHeaderBytes` at `p` (at `offset` of `file_bytes`) are not a plausible event
/// header, or nullopt when they are (then *channel_len and *data_len are set).
std::optional<std::string> lcm_header_problem(const unsigned char* p, std::uint64_t offset, std::uint64_t file_bytes,
                                              std::uint32_t* channel_len, std::uint32_t* data_len);

/// Scans `bytes` in order, calling `on_event` for every complete event, including those after
/// damage (resynchronising on the sync word). Pure: no allocation proportional to any length in the
/// input. An exception from `on_event` propagates.
LcmLogScan scan_lcmlog(std::span<const unsigned char> bytes, const std::function<void(const LcmEventRef&)>& on_event);

/// Decodes an event's payload as LCM type Msg with the bounded decoder every pofkit reader uses
/// (pof/lcm/decode.hpp: lengths checked against the payload before lcm-gen's decoder allocates;
/// fuzz_lcmlog found a raw_block_t claiming n_scans = 2^31 - 1 asking for 48 GiB, and a string
/// length of INT32_MIN overflowing `length - 1`). Returns why it does not decode, or nullopt.
template <typename Msg>
std::optional<std::string> decode_lcm_event(const LcmEventRef& ev, Msg& m) noexcept {
  const lcmutil::DecodeResult r = lcmutil::decode(ev.data, ev.data_size, m);
  if (r) return std::nullopt;
  try {
    return r.describe();
  } catch (...) {
    return std::string("not decodable");
  }
}

/// A log file opened for scanning, and the damage its readers found. Belongs to one thread.
class LcmLogReader {
 public:
  /// Opens `path` (see the file comment for input that is not a regular file). Throws NoInputError
  /// when it cannot be opened, DataError when a stream is not an LCM log or is too long.
  explicit LcmLogReader(std::string path, std::uint64_t max_stream_bytes = kLcmLogMaxStreamBytes);
  /// A log already in memory, e.g. read from a stream whose first bytes were consumed to sniff the
  /// format, or a fuzzer's input. `name` is used in messages.
  LcmLogReader(std::string name, std::vector<unsigned char> bytes);
  /// The rest of a stream (not a regular file) whose first bytes `head` were already read.
  LcmLogReader(std::string name, int stream_fd, std::vector<unsigned char> head,
               std::uint64_t max_stream_bytes = kLcmLogMaxStreamBytes);
  ~LcmLogReader();
  LcmLogReader(const LcmLogReader&) = delete;
  LcmLogReader& operator=(const LcmLogReader&) = delete;

  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] std::span<const unsigned char> bytes() const { return {data_, size_}; }

  /// scan_lcmlog() over the whole file; the result is also kept for damage_report().
  const LcmLogScan& scan(const std::function<void(const LcmEventRef&)>& on_event);
  /// Counts an event whose payload a caller could not use; the first one is named in the report.
  void undecodable(const LcmEventRef& ev, const std::string& why);

  [[nodiscard]] const LcmLogScan& result() const { return scan_; }
  [[nodiscard]] std::uint64_t undecodable_events() const { return undecodable_; }
  [[nodiscard]] bool damaged() const { return !scan_.clean() || undecodable_ > 0; }
  /// One line for an error message: the file, the byte offset and cause of the first damage, and
  /// the counts ("run.lcmlog: damaged LCM log: first damage at byte 2048: bad sync word ...; 1
  /// damaged region (96 bytes) skipped, at least 1 event lost; 0 events not decodable; 7619
  /// complete events read").
  [[nodiscard]] std::string damage_report() const;

 private:
  void read_stream(int fd, bool device, std::uint64_t max_bytes);

  std::string path_;
  const unsigned char* data_ = nullptr;
  std::uint64_t size_ = 0;
  void* map_ = nullptr;  // munmap on destruction
  std::vector<unsigned char> owned_;
  LcmLogScan scan_;
  std::uint64_t undecodable_ = 0;
  std::uint64_t first_undecodable_offset_ = 0;
  std::string first_undecodable_why_;
};

}  // namespace pof::io
