// The lossless recording session; the why is in pof/recorder/session.hpp.
#include "pof/recorder/session.hpp"

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>

#include <spdlog/spdlog.h>

#include "pof/base/errors.hpp"
#include "pof/bus/channel_filter.hpp"
#include "pof/bus/receiver.hpp"
#include "pof/bus/udp_socket.hpp"
#include "pof/bus/url.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/lcm/utime.hpp"
#include "pof/recorder/manifest_state.hpp"

namespace pof::recorder {
namespace fs = std::filesystem;
namespace {

using pof::lcmutil::iso_utc;
using pof::lcmutil::now_utime;

// Overwrites `path` with `text` in the blocks it already has. The manifest is normally replaced by
// write-then-rename (io::write_file_atomic), which needs room for a second copy: on a file system
// that filled up during the session there is none, and the manifest would go on saying
// "recording" for a session that failed. The old manifest's own blocks need no allocation, so the
// text is written there, but only when it fits in them (st_blocks) and under RLIMIT_FSIZE: the
// write then cannot stop half-way for lack of space. Not atomic against a crash in the middle,
// hence the fallback only. Returns "" or why it did not.
std::string overwrite_in_place(const fs::path& path, const std::string& text) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) return std::string("cannot open: ") + std::strerror(errno);
  std::string why;
  struct stat st {};
  rlimit fsize{};
  if (::fstat(fd, &st) != 0) {
    why = std::string("cannot stat: ") + std::strerror(errno);
  } else if (static_cast<uint64_t>(st.st_blocks) * 512u < text.size()) {
    why = "the new text (" + std::to_string(text.size()) + " bytes) does not fit in the " +
          std::to_string(st.st_blocks * 512) + " bytes the file has";
  } else if (::getrlimit(RLIMIT_FSIZE, &fsize) == 0 && fsize.rlim_cur != RLIM_INFINITY && fsize.rlim_cur < text.size()) {
    why = "the new text (" + std::to_string(text.size()) + " bytes) exceeds the file size limit";
  } else {
    std::size_t done = 0;
    while (done < text.size() && why.empty()) {
      const ssize_t w = ::pwrite(fd, text.data() + done, text.size() - done, static_cast<off_t>(done));
      if (w < 0 && errno == EINTR) continue;
      if (w <= 0) why = std::string("write failed: ") + std::strerror(w < 0 ? errno : ENOSPC);
      else done += static_cast<std::size_t>(w);
    }
    if (why.empty() && (::ftruncate(fd, static_cast<off_t>(text.size())) != 0 || ::fdatasync(fd) != 0))
      why = std::string("cannot truncate or sync: ") + std::strerror(errno);
  }
  ::close(fd);
  return why;
}

}  // namespace

const char* outcome_name(Outcome o) {
  switch (o) {
    case Outcome::kRunning: return "recording";
    case Outcome::kStopped: return "stopped";
    case Outcome::kDiskFull: return "disk_full";
    case Outcome::kIoError: return "io_error";
    case Outcome::kFailed: return "failed";
  }
  return "?";
}

Session::Session(SessionOptions options) : opt_(std::move(options)) {
  if (opt_.output.empty()) throw pof::ConfigError("pof record: no output file given (--output)");
  { bus::ChannelFilter check(opt_.channels); }  // a bad regex fails here, before anything is created
  if (opt_.rotate_seconds < 0 || opt_.sync_interval_s <= 0)
    throw pof::ConfigError("--rotate-seconds must be >= 0 and --sync-interval > 0");
  // The output: a directory gets a timestamped file (the service records into /var/lib/pof).
  base_ = opt_.output;
  const std::string s = base_.string();
  if (fs::is_directory(base_) || (!s.empty() && s.back() == '/')) {
    if (!fs::is_directory(base_))
      throw pof::IoError(s + ": output directory does not exist");
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    ::gmtime_r(&t, &tm);
    char name[64];
    std::strftime(name, sizeof name, "pof-%Y%m%dT%H%M%SZ.lcmlog", &tm);
    base_ = base_ / name;
  }
  if (!base_.has_parent_path()) base_ = fs::path(".") / base_;
  if (!fs::is_directory(base_.parent_path()))
    throw pof::IoError(base_.parent_path().string() + ": output directory does not exist");
  fs::path stem = base_.parent_path() / base_.stem();
  manifest_path_ = stem.string() + ".manifest.json";
  attach_dir_ = stem.string() + ".files";
  for (unsigned i = 0; i < 1; ++i) {
    if (fs::exists(file_path(i)))
      throw pof::IoError(file_path(i).string() + ": exists; pof record never overwrites a recording");
  }
  if (fs::exists(manifest_path_))
    throw pof::IoError(manifest_path_.string() + ": exists; pof record never overwrites a recording");
  for (const auto& f : opt_.manifest_files) {
    if (!fs::is_regular_file(f)) throw pof::NoInputError(f.string() + ": --manifest-file: no such file");
  }

  url_ = bus::resolve_url(opt_.lcm_url, opt_.recv_buf_bytes);
  recorder_ = this_recorder();
  const bus::UdpmUrl udpm = bus::parse_udpm_url(url_);
  port_ = udpm.ok() ? udpm.port : 0;  // 0: not udpm (no kernel socket statistics)
}

Session::~Session() {
  try {
    stop();
  } catch (...) {
  }
}

fs::path Session::file_path(unsigned index) const {
  if (opt_.rotate_bytes == 0 && opt_.rotate_seconds == 0) return base_;
  char n[16];
  std::snprintf(n, sizeof n, ".%04u", index);
  return base_.parent_path() / (base_.stem().string() + n + base_.extension().string());
}

void Session::start() {
  if (started_) return;
  start_utime_ = now_utime();
  // Attachments first: a missing or unreadable calibration must fail before anything is recorded.
  if (!opt_.manifest_files.empty()) {
    std::error_code ec;
    fs::create_directory(attach_dir_, ec);
    if (ec) throw pof::IoError(attach_dir_.string() + ": cannot create: " + ec.message());
    for (const auto& f : opt_.manifest_files) {
      const fs::path dst = attach_dir_ / f.filename();
      if (!fs::copy_file(f, dst, fs::copy_options::overwrite_existing, ec) || ec)
        throw pof::IoError(dst.string() + ": cannot copy " + f.string() + ": " + ec.message());
      attachments_.push_back({{"source", fs::absolute(f).string()},
                              {"copy", (attach_dir_.filename() / f.filename()).string()},
                              {"bytes", fs::file_size(dst)}});
    }
  }

  bus::ReceiverOptions ro;
  ro.lcm_queue_capacity = opt_.lcm_queue_capacity;
  ro.udpm_via_liblcm = opt_.use_liblcm;
  // Authenticated mode: the Receiver verifies every subscribed message before the raw handler sees
  // it, drops and counts what fails, and hands over what passes without its trailer.
  ro.auth_key = opt_.auth_key;
  ro.auth = opt_.auth;
  rx_ = std::make_unique<bus::Receiver>(url_, ro);
  direct_ = rx_->direct();
  // The receive thread only copies each message into the hand-off queue (enqueue() does not throw:
  // the arena is reserved below and never grows).
  rx_->subscribe_raw(opt_.channels, [this](const bus::Delivery& d, const unsigned char* data, std::size_t size) {
    enqueue(d.recv_utime, d.channel, data, static_cast<uint32_t>(size));  // <= 16 MiB (UdpmLimits), u32 in liblcm
  });

  if (port_ != 0) {
    const auto socks = bus::udp_sockets(port_);
    for (const auto& so : socks) udp_drops_at_start_ += so.drops;
    // SO_RCVBUF reads back twice what was granted (the kernel's bookkeeping allowance, socket(7));
    // less than asked means net.core.rmem_max capped it.
    if (!socks.empty() && socks.front().rcvbuf_bytes / 2 < opt_.recv_buf_bytes) {
      spdlog::warn("the kernel granted a UDP receive buffer of {} bytes (asked {}; net.core.rmem_max = {}): "
                   "bursts may be lost; install deploy/sysctl.d/60-pof-lcm.conf",
                   socks.front().rcvbuf_bytes / 2, opt_.recv_buf_bytes, bus::rmem_max());
    }
  }
  // A session of an earlier recorder that was killed still says "recording": say what it is.
  for (const auto& p : mark_interrupted(base_.parent_path()))
    spdlog::warn("{}: said 'recording' but its recorder is gone: marked 'interrupted'", p.string());
  if (!open_next_file()) throw pof::IoError(error_);
  // The hand-off arena never reallocates (a realloc would copy up to handoff_bytes inside the
  // receive thread's critical section while datagrams pile up in the kernel). Reserving is virtual
  // memory only: pages are touched as the queue first fills.
  pending_.reserve(opt_.handoff_bytes);
  try {
    write_manifest("recording");
  } catch (...) {
    // No room even for the manifest: nothing is recorded, so the log just created goes too.
    const fs::path p = writer_->path();
    writer_.reset();
    files_.clear();
    std::error_code ec;
    fs::remove(p, ec);
    throw;
  }
  started_ = true;
  writer_thread_ = std::thread([this] { writer_loop(); });
  lcm_thread_ = std::thread([this] { lcm_loop(); });
}

// Receive thread: copy and hand off, nothing else (no disk, no logging).
void Session::enqueue(int64_t utime, std::string_view channel, const void* data, uint32_t data_size) {
  const std::size_t size = kRecordHeader + channel.size() + data_size;
  std::lock_guard lk(mu_);
  ++received_;
  if (!accepting_) {  // writing stopped (disk full, I/O error): counted as not written
    ++refused_;
    return;
  }
  if (pending_bytes_ + size > opt_.handoff_bytes) {
    ++dropped_;
    return;
  }
  const std::size_t at = pending_.size();
  pending_.resize(at + size);
  unsigned char* p = pending_.data() + at;
  const uint32_t cl = static_cast<uint32_t>(channel.size());
  std::memcpy(p, &utime, 8);
  std::memcpy(p + 8, &cl, 4);
  std::memcpy(p + 12, &data_size, 4);
  std::memcpy(p + kRecordHeader, channel.data(), cl);
  if (data_size > 0) std::memcpy(p + kRecordHeader + cl, data, data_size);
  pending_bytes_ += size;
  if (pending_bytes_ > peak_bytes_) peak_bytes_ = pending_bytes_;
  if (++pending_events_ == 1) cv_.notify_one();
}

void Session::lcm_loop() {
  // The receive thread is the one that must never starve (the kernel buffer holds ~0.2 s at
  // 100k msg/s); the writer can lag by the whole hand-off queue. Raise its priority when allowed
  // (root or CAP_SYS_NICE; the unit can grant Nice= instead); failure is harmless.
  if (opt_.receive_nice != 0) ::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), opt_.receive_nice);
  while (!stop_lcm_.load()) {
    rx_->handle(50);
    const bus::ReceiverStats st = rx_->stats();
    malformed_.store(st.malformed_datagrams, std::memory_order_relaxed);
    incomplete_.store(st.incomplete_messages, std::memory_order_relaxed);
    auth_unsigned_.store(st.auth_unsigned, std::memory_order_relaxed);
    auth_bad_mac_.store(st.auth_bad_mac, std::memory_order_relaxed);
    auth_stale_.store(st.auth_stale, std::memory_order_relaxed);
    auth_replayed_.store(st.auth_replayed, std::memory_order_relaxed);
    lcm_beats_.fetch_add(1);
  }
}

bool Session::open_next_file() {
  const fs::path p = file_path(file_index_);
  try {
    auto w = std::make_unique<DurableLogWriter>(p);
    std::lock_guard lk(stats_mu_);
    writer_ = std::move(w);
    files_.push_back(FileInfo{p, 0, 0, 0, 0});
  } catch (const pof::Error& e) {
    std::lock_guard lk(stats_mu_);
    outcome_ = Outcome::kIoError;
    error_ = e.what();
    return false;
  }
  ++file_index_;
  file_bytes_ = 0;
  file_opened_ = std::chrono::steady_clock::now();
  return true;
}

// Writer thread: close the current file (synced) and open the next one.
bool Session::rotate() {
  if (writer_->close() != WriteStatus::kOk) return false;
  {
    std::lock_guard lk(stats_mu_);
    files_.back().events = writer_->events_written();
    files_.back().bytes = writer_->bytes_written();
  }
  if (!open_next_file()) return false;
  write_manifest_noexcept("recording");
  return true;
}

void Session::note_write_failure() {
  const fs::path p = writer_->path();
  const std::string why = std::strerror(writer_->error_errno());
  const Outcome stopped = writer_->status() == WriteStatus::kNoSpace ? Outcome::kDiskFull : Outcome::kIoError;
  if (writer_->bytes_written() > 0) {
    outcome_ = stopped;
    error_ = p.string() + ": " + why + " after " + std::to_string(writer_->events_written()) + " events (" +
             std::to_string(writer_->bytes_written()) + " bytes) in this file; the log is complete up to there";
    return;
  }
  // Not one complete event in the file (the writer cut the failed batch back to 0 bytes): remove it,
  // never leave a 0-byte log behind.
  writer_->close();
  writer_.reset();
  files_.pop_back();
  std::error_code ec;
  fs::remove(p, ec);
  const std::string removed =
      ec ? "; the empty log file could not be removed: " + ec.message() : "; the empty log file was removed";
  if (files_.empty()) {
    outcome_ = Outcome::kFailed;
    error_ = p.string() + ": cannot write the first event: " + why + "; nothing was recorded" + removed;
  } else {
    outcome_ = stopped;
    error_ = p.string() + ": cannot write its first event: " + why + removed + "; the log is complete up to " +
             files_.back().path.string();
  }
}

void Session::write_manifest_noexcept(const char* status) noexcept {
  try {
    write_manifest(status);
  } catch (const std::exception& e) {
    spdlog::warn("manifest not updated: {}", e.what());
  }
}

// Writer thread, under stats_mu_: one event the current file holds.
void Session::note_event(int64_t utime, std::string_view channel, const unsigned char* data, uint32_t size) {
  FileInfo& fi = files_.back();
  if (fi.first_utime == 0) fi.first_utime = utime;
  fi.last_utime = utime;
  auto it = channels_.find(channel);
  if (it == channels_.end()) {
    // The event is in the log already; only its per-channel bookkeeping is bounded.
    if (!admit_channel(channel, channels_.size())) {
      other_.note(channel, size);
      return;
    }
    it = channels_.emplace(std::string(channel), ChannelStats{}).first;
    it->second.fingerprint = bus::fingerprint_of(data, size);
    it->second.type = bus::message_type_of(data, size);
  }
  ChannelStats& cs = it->second;
  ++cs.events;
  cs.bytes += size;
  if (cs.type != bus::MessageType::kUnknown) {
    if (auto sq = pof_seq(data, size)) cs.seq.update(*sq);
  }
}

void Session::writer_loop() {
  std::vector<unsigned char> batch;
  batch.reserve(opt_.handoff_bytes);  // swapped with pending_: both stay at full capacity
  auto last_sync = std::chrono::steady_clock::now();
  bool failed = false;
  // Events of the batch appended to the writer and not yet known to be in the file.
  struct Event {
    int64_t utime;
    std::string_view channel;
    const unsigned char* data;
    uint32_t size;
  };
  std::vector<Event> unbooked;
  for (;;) {
    uint64_t taken = 0;  // events in this batch
    {
      std::unique_lock lk(mu_);
      cv_.wait_for(lk, std::chrono::milliseconds(50), [this] { return !pending_.empty() || stop_writer_.load(); });
      batch.clear();
      batch.swap(pending_);
      taken = pending_events_;
      pending_bytes_ = 0;
      pending_events_ = 0;
    }
    {
      std::lock_guard lk(stats_mu_);
      taken_ += taken;
    }
    writer_beats_.fetch_add(1);
    const bool stopping = stop_writer_.load();
    if (!failed) {
      const auto now = std::chrono::steady_clock::now();
      if (opt_.rotate_seconds > 0 && !batch.empty() && writer_->events_appended() > 0 &&
          std::chrono::duration<double>(now - file_opened_).count() >= opt_.rotate_seconds) {
        rotate();
      }
      // Per-file and per-channel bookkeeping only for events the file holds: a failed write(2) cuts
      // the writer's batch back (lcmlog_durable.hpp), and those events are counted as not written.
      unbooked.clear();
      auto book = [&](uint64_t keep) {  // all but the last `keep` events are in the file
        const std::size_t n = unbooked.size() - std::min<std::size_t>(keep, unbooked.size());
        if (n == 0) return;
        std::lock_guard lk(stats_mu_);
        for (std::size_t i = 0; i < n; ++i) note_event(unbooked[i].utime, unbooked[i].channel, unbooked[i].data,
                                                       unbooked[i].size);
        unbooked.erase(unbooked.begin(), unbooked.begin() + static_cast<std::ptrdiff_t>(n));
      };
      for (std::size_t off = 0; off + kRecordHeader <= batch.size();) {
        Event e{};
        uint32_t cl = 0;
        std::memcpy(&e.utime, batch.data() + off, 8);
        std::memcpy(&cl, batch.data() + off + 8, 4);
        std::memcpy(&e.size, batch.data() + off + 12, 4);
        e.channel = std::string_view(reinterpret_cast<const char*>(batch.data() + off + kRecordHeader), cl);
        e.data = batch.data() + off + kRecordHeader + cl;
        off += kRecordHeader + cl + e.size;
        const uint64_t n = kLogHeaderBytes + cl + e.size;
        if (opt_.rotate_bytes > 0 && writer_->events_appended() > 0 && file_bytes_ + n > opt_.rotate_bytes) {
          if (writer_->flush() != WriteStatus::kOk) break;
          book(0);
          if (!rotate()) break;
        }
        if (writer_->append(e.utime, e.channel, e.data, e.size) != WriteStatus::kOk) break;
        file_bytes_ += n;
        unbooked.push_back(e);
        book(writer_->events_appended() - writer_->events_written());
      }
      if (writer_->status() == WriteStatus::kOk) writer_->flush();
      if (writer_->status() == WriteStatus::kOk) book(0);
      unbooked.clear();  // cut back by a failed write: not in the file
      if (writer_->status() == WriteStatus::kOk &&
          (stopping || std::chrono::steady_clock::now() - last_sync >= std::chrono::duration<double>(opt_.sync_interval_s))) {
        writer_->sync();
        last_sync = std::chrono::steady_clock::now();
      }
      {
        std::lock_guard lk(stats_mu_);
        if (writer_) {
          files_.back().events = writer_->events_written();
          files_.back().bytes = writer_->bytes_written();
        }
        written_ = 0;
        for (const auto& f : files_) written_ += f.events;
        if (writer_ && writer_->status() != WriteStatus::kOk && outcome_ == Outcome::kRunning) note_write_failure();
        failed = outcome_ != Outcome::kRunning;
        writer_failed_ = failed;
      }
      if (failed) {
        std::lock_guard lk(mu_);
        accepting_ = false;
      }
    }
    batch.clear();
    if (stopping) {
      std::lock_guard lk(mu_);
      if (pending_.empty()) break;
    }
  }
  if (writer_) writer_->close();
}

SessionStats Session::poll() {
  SessionStats s;
  {
    std::lock_guard lk(mu_);
    s.received = received_;
    s.dropped_handoff = dropped_;
    s.not_written = refused_;
    s.handoff_peak_bytes = peak_bytes_;
  }
  {
    std::lock_guard lk(stats_mu_);
    s.outcome = outcome_;
    s.error = error_;
    s.written = written_;
    s.not_written += not_written_locked();
    for (const auto& f : files_) s.files.push_back(f.path);
  }
  if (port_ != 0) {
    const auto socks = bus::udp_sockets(port_);
    uint64_t d = 0;
    for (const auto& so : socks) d += so.drops;
    s.udp_drops = d >= udp_drops_at_start_ ? d - udp_drops_at_start_ : 0;
    if (!socks.empty()) s.udp_rcvbuf_bytes = socks.front().rcvbuf_bytes;
  }
  s.malformed_datagrams = malformed_.load(std::memory_order_relaxed);
  s.incomplete_messages = incomplete_.load(std::memory_order_relaxed);
  s.authenticated = opt_.auth_key != nullptr;
  s.auth_unsigned = auth_unsigned_.load(std::memory_order_relaxed);
  s.auth_bad_mac = auth_bad_mac_.load(std::memory_order_relaxed);
  s.auth_stale = auth_stale_.load(std::memory_order_relaxed);
  s.auth_replayed = auth_replayed_.load(std::memory_order_relaxed);
  s.manifest = manifest_path_;
  return s;
}

SessionStats Session::stop() {
  if (!started_ || stopped_) return poll();
  stopped_ = true;
  // Last look at the kernel counters while the socket still exists.
  SessionStats before = poll();
  stop_lcm_.store(true);
  if (lcm_thread_.joinable()) lcm_thread_.join();
  stop_writer_.store(true);
  cv_.notify_one();
  if (writer_thread_.joinable()) writer_thread_.join();
  stop_utime_ = now_utime();
  SessionStats s = poll();
  s.udp_drops = before.udp_drops;
  s.udp_rcvbuf_bytes = before.udp_rcvbuf_bytes;
  {
    std::lock_guard lk(stats_mu_);
    if (outcome_ == Outcome::kRunning) outcome_ = Outcome::kStopped;
    s.outcome = outcome_;
  }
  final_udp_drops_ = s.udp_drops;
  final_rcvbuf_ = s.udp_rcvbuf_bytes;
  write_final_manifest(outcome_name(s.outcome));
  rx_.reset();
  return s;
}

void Session::write_manifest(const char* status) { io::write_file_atomic(manifest_path_, manifest_text(status)); }

void Session::write_final_manifest(const char* status) noexcept {
  std::string text;
  try {
    text = manifest_text(status);
    io::write_file_atomic(manifest_path_, text);
    return;
  } catch (const std::exception& e) {
    if (text.empty()) {
      spdlog::warn("manifest not updated: {}", e.what());
      return;
    }
    const std::string why = overwrite_in_place(manifest_path_, text);
    if (why.empty()) {
      spdlog::warn("{}; the manifest was rewritten in place instead", e.what());
    } else {
      spdlog::warn("manifest not updated: {}; nor in place: {}", e.what(), why);
    }
  }
}

// Under stats_mu_: events the writer took from the hand-off and that will never reach the log
// (writing stopped). While writing goes on, what is taken and not yet written is in flight.
uint64_t Session::not_written_locked() const { return writer_failed_ && taken_ > written_ ? taken_ - written_ : 0; }

std::string Session::error_reason() {
  std::lock_guard lk(stats_mu_);
  return std::string(outcome_name(outcome_)) + ": " + error_;
}

std::string Session::manifest_text(const char* status) {
  nlohmann::json m;
  m["schema_version"] = 1;
  m["kind"] = "pof record session";
  m["status"] = status;
  m["start_utime"] = start_utime_;
  m["start_utc"] = iso_utc(start_utime_);
  if (stop_utime_ != 0) {
    m["stop_utime"] = stop_utime_;
    m["stop_utc"] = iso_utc(stop_utime_);
  }
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  m["host"] = host;
  // Who records: a reader tells a live session from one whose recorder was killed
  // (pof/recorder/manifest_state.hpp).
  m["recorder"] = recorder_;
  m["lcm_url"] = url_;
  m["receiver"] = receiver_name();
  m["channel_regex"] = opt_.channels;
  m["options"] = {{"rotate_bytes", opt_.rotate_bytes},
                  {"rotate_seconds", opt_.rotate_seconds},
                  {"sync_interval_s", opt_.sync_interval_s},
                  {"lcm_queue_capacity", opt_.lcm_queue_capacity},
                  {"handoff_bytes", opt_.handoff_bytes}};
  for (const auto& [k, v] : opt_.manifest_extra.items()) m[k] = v;
  m["attachments"] = attachments_;
  SessionStats s;
  std::size_t peak = 0;
  {
    std::lock_guard lk(mu_);
    s.received = received_;
    s.dropped_handoff = dropped_;
    s.not_written = refused_;
    peak = peak_bytes_;
  }
  nlohmann::json files = nlohmann::json::array();
  nlohmann::json chans = nlohmann::json::object();
  {
    std::lock_guard lk(stats_mu_);
    for (const auto& f : files_)
      files.push_back({{"name", f.path.filename().string()},
                       {"events", f.events},
                       {"bytes", f.bytes},
                       {"first_utime", f.first_utime},
                       {"last_utime", f.last_utime}});
    for (const auto& [name, c] : channels_) {
      nlohmann::json j = {{"events", c.events}, {"bytes", c.bytes}, {"type", bus::message_type_name(c.type)}};
      char fp[24];
      std::snprintf(fp, sizeof fp, "0x%016llx", static_cast<unsigned long long>(c.fingerprint));
      j["fingerprint"] = fp;
      if (c.seq.have)
        j["seq"] = {{"first", c.seq.first}, {"last", c.seq.last}, {"gaps", c.seq.gaps}, {"missing", c.seq.missing},
                    {"restarts", c.seq.restarts}};
      chans[name] = j;
    }
    s.written = written_;
    s.not_written += not_written_locked();
    if (!error_.empty()) m["error"] = error_;
    // Events on names beyond the bound (pof/recorder/channel_cap.hpp): in the log, counted here.
    m["other_channels"] = {{"events", other_.events},
                           {"bytes", other_.bytes},
                           {"examples", other_.examples},
                           {"tracked_limit", kMaxTrackedChannels},
                           {"pof_reserve", kPofChannelReserve}};
  }
  m["files"] = files;
  m["channels"] = chans;
  m["counters"] = {{"received", s.received},
                   {"written", s.written},
                   {"dropped_handoff", s.dropped_handoff},
                   {"not_written", s.not_written},
                   {"not_written_reason", s.not_written > 0 ? error_reason() : std::string()},
                   {"udp_kernel_drops", final_udp_drops_},
                   {"malformed_datagrams", malformed_.load(std::memory_order_relaxed)},
                   {"incomplete_messages", incomplete_.load(std::memory_order_relaxed)},
                   {"udp_rcvbuf_bytes", final_rcvbuf_},
                   {"handoff_peak_bytes", peak}};
  // Authenticated mode: the log holds only messages that passed the Receiver's verification,
  // without trailers; the drops are its counters (bus::ReceiverStats), per verdict.
  if (opt_.auth_key)
    m["authentication"] = {{"enabled", true},
                           {"key_id", bus::auth::key_id_hex(opt_.auth_key->id())},
                           {"window_s", static_cast<double>(opt_.auth.window_us) / 1e6},
                           {"dropped",
                            {{"unsigned", auth_unsigned_.load(std::memory_order_relaxed)},
                             {"bad_mac", auth_bad_mac_.load(std::memory_order_relaxed)},
                             {"stale", auth_stale_.load(std::memory_order_relaxed)},
                             {"replayed", auth_replayed_.load(std::memory_order_relaxed)}}}};
  else
    m["authentication"] = {{"enabled", false}};
  return m.dump(2) + "\n";
}

}  // namespace pof::recorder
