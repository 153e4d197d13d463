// `pof record`: lossless LCM session recording (pof/recorder/session.hpp says why lcm-logger is not
// enough), plus `--check` and `--repair` for logs cut short by SIGKILL or power loss.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <spdlog/spdlog.h>

#include "auth_options.hpp"
#include "commands.hpp"
#include "pof/bus/url.hpp"
#include "pof/lcm/utime.hpp"
#include "pof/base/errors.hpp"
#include "pof/bus/fingerprint.hpp"
#include "pof/recorder/lcmlog_durable.hpp"
#include "pof/recorder/manifest_state.hpp"
#include "pof/recorder/pof_messages.hpp"
#include "pof/recorder/session.hpp"
#include "pof/service/cli_checks.hpp"
#include "pof/service/sd_notify.hpp"
#include "pof/service/signals.hpp"

namespace pof::cli {
namespace {

namespace rec = pof::recorder;

struct RecordArgs {
  std::string output;
  std::string url;
  std::string channels = ".*";
  double rotate_mb = 0;
  double rotate_seconds = 0;
  double duration_s = 0;
  double sync_interval_s = 0.5;
  int queue_capacity = 1 << 20;
  double handoff_mb = 256;
  AuthArgs auth;
  std::vector<std::string> manifest_files;
  std::vector<std::string> check;
  std::string repair;
  bool quiet = false;
  bool liblcm = false;
};


// Prints what a log holds; returns true when it is clean.
bool check_one(const std::string& file) {
  std::map<std::string, rec::SeqTracker> seqs;
  std::map<std::string, bus::MessageType> types;
  const rec::LogCheck c = rec::scan_log(file, [&](const rec::LogEventRef& e) {
    const std::string ch(e.channel);
    auto t = types.find(ch);
    if (t == types.end()) t = types.emplace(ch, bus::message_type_of(e.data, e.data_size)).first;
    if (t->second != bus::MessageType::kUnknown) {
      if (auto s = rec::pof_seq(e.data, e.data_size)) seqs[ch].update(*s);
    }
  });
  std::cout << file << ": " << c.events << " complete events, " << c.good_bytes << " bytes";
  if (c.events > 0)
    std::printf("%s", (", " + pof::lcmutil::iso_utc(c.first_utime, false) + " .. " + pof::lcmutil::iso_utc(c.last_utime, false) + " (" +
                       std::to_string(static_cast<double>(c.last_utime - c.first_utime) / 1e6) + " s)")
                          .c_str());
  std::cout << std::flush;
  std::printf("\n");
  for (const auto& [ch, n] : c.channel_events) {
    std::printf("  %-28s %-14s %10llu events", ch.c_str(), bus::message_type_name(types[ch]),
                static_cast<unsigned long long>(n));
    if (auto s = seqs.find(ch); s != seqs.end())
      std::printf("  seq %lld..%lld, %llu gaps (%llu missing), %llu restarts", static_cast<long long>(s->second.first),
                  static_cast<long long>(s->second.last), static_cast<unsigned long long>(s->second.gaps),
                  static_cast<unsigned long long>(s->second.missing),
                  static_cast<unsigned long long>(s->second.restarts));
    std::printf("\n");
  }
  if (rec::log_is_being_written(file))
    std::printf("  (being recorded right now: the tail may still be in flight)\n");
  // The session's manifest: a killed recorder's still says "recording" (pof/recorder/manifest_state.hpp).
  if (const auto manifest = rec::manifest_of_log(file); !manifest.empty()) {
    const rec::ManifestState st = rec::read_manifest_state(manifest);
    if (st.status == "interrupted")
      std::printf("  session INTERRUPTED (%s says 'recording', but %s): the log holds what was written before\n",
                  manifest.filename().c_str(), st.why.c_str());
    else if (!st.status.empty())
      std::printf("  session %s (%s)%s%s\n", st.status.c_str(), manifest.filename().c_str(), st.why.empty() ? "" : ": ",
                  st.why.c_str());
  }
  if (c.clean()) {
    std::printf("  clean: ends on a complete event\n");
  } else if (c.events_after_damage == 0) {
    std::printf("  TORN TAIL: %llu bytes after the last complete event, at offset %llu (%s)\n",
                static_cast<unsigned long long>(c.torn_bytes()), static_cast<unsigned long long>(c.good_bytes),
                c.problem.c_str());
  } else {
    std::printf("  DAMAGED at offset %llu (%s); %llu complete events follow the damage; %llu bytes in %llu damaged "
                "region(s), at least %llu event(s) lost\n",
                static_cast<unsigned long long>(c.good_bytes), c.problem.c_str(),
                static_cast<unsigned long long>(c.events_after_damage), static_cast<unsigned long long>(c.damaged_bytes),
                static_cast<unsigned long long>(c.damaged_regions), static_cast<unsigned long long>(c.lost_events));
  }
  std::fflush(stdout);
  return c.clean();
}

void run_check(const std::vector<std::string>& files) {
  std::vector<std::string> bad;
  for (const auto& f : files)
    if (!check_one(f)) bad.push_back(f);
  if (!bad.empty()) {
    std::string list;
    for (const auto& f : bad) list += " " + f;
    throw pof::DataError("torn or damaged LCM log:" + list + " (repair with: pof record --repair FILE)");
  }
}

void run_repair(const std::string& file) {
  const rec::RepairResult r = rec::repair_log(file);
  std::printf("%s: %s\n", file.c_str(), r.action.c_str());
  std::fflush(stdout);
  const rec::LogCheck after = rec::check_log(file);
  if (!after.clean()) throw pof::IoError(file + ": still not clean after repair at offset " + std::to_string(after.good_bytes));
}

void run_record(const RecordArgs& a) {
  rec::SessionOptions o;
  o.output = a.output;
  o.lcm_url = a.url;
  o.channels = a.channels;
  o.rotate_bytes = static_cast<uint64_t>(a.rotate_mb * 1024.0 * 1024.0);
  o.rotate_seconds = a.rotate_seconds;
  o.sync_interval_s = a.sync_interval_s;
  o.lcm_queue_capacity = a.queue_capacity;
  o.handoff_bytes = static_cast<std::size_t>(a.handoff_mb * 1024.0 * 1024.0);
  for (const auto& f : a.manifest_files) o.manifest_files.emplace_back(f);
  o.use_liblcm = a.liblcm;
  const Auth auth = load_auth(a.auth);
  o.auth_key = auth.key;
  o.auth = auth.settings;
  o.manifest_extra["versions"] = {
      {"pofkit", POF_VERSION},
      {"git", git_describe()},
      {"lcm", std::to_string(LCM_MAJOR_VERSION) + "." + std::to_string(LCM_MINOR_VERSION) + "." +
                  std::to_string(LCM_MICRO_VERSION)}};

  // Signals are taken by this thread's loop; blocked before the session threads start so they
  // inherit the mask. EFBIG must come back as an error, not kill us.
  const service::SignalWaiter signals;
  service::ignore_write_signals();

  service::ServiceNotifier notifier;
  rec::Session session(o);
  session.start();
  const auto first = session.poll();
  if (!a.quiet)
    spdlog::info("recording '{}' from {} ({}) into {} (manifest {})", a.channels, session.url(), session.receiver_name(),
                 first.files.empty() ? std::string("?") : first.files.front().string(), first.manifest.string());
  if (!a.quiet && auth.key)
    spdlog::info("authenticated mode: bus key {} (key id {}), freshness window {} s: only verified messages are "
                 "recorded, without their trailers",
                 auth.key_file, bus::auth::key_id_hex(auth.key->id()), a.auth.window_s);
  notifier.ready("recording into " + (first.files.empty() ? std::string("?") : first.files.front().string()));

  const auto t0 = std::chrono::steady_clock::now();
  auto last_status = t0;
  uint64_t last_writer = session.writer_heartbeat();
  uint64_t last_lcm = session.lcm_heartbeat();
  for (;;) {
    const int sig = signals.wait(std::chrono::milliseconds(100));
    if (service::SignalWaiter::is_stop(sig)) break;
    if (sig == SIGHUP) {
      // Nothing to reload: the session's options are fixed. Acknowledge so it is not mistaken.
      spdlog::info("SIGHUP ignored: pof record has nothing to reload");
    }
    const auto s = session.poll();
    if (s.outcome != rec::Outcome::kRunning) break;
    const auto now = std::chrono::steady_clock::now();
    if (a.duration_s > 0 && std::chrono::duration<double>(now - t0).count() >= a.duration_s) break;
    // Watchdog only while both threads are alive (their heartbeats move at >= 20 Hz).
    const uint64_t w = session.writer_heartbeat();
    const uint64_t l = session.lcm_heartbeat();
    if (w != last_writer && l != last_lcm) {
      notifier.watchdog_if_due();
      last_writer = w;
      last_lcm = l;
    }
    if (now - last_status >= std::chrono::seconds(1)) {
      last_status = now;
      notifier.status("recording: " + std::to_string(s.written) + " events written, " +
                      std::to_string(s.dropped_handoff) + " dropped, " +
                      (s.not_written > 0 ? std::to_string(s.not_written) + " not written (" + s.error + "), " : std::string()) +
                      std::to_string(s.udp_drops) +
                      " kernel UDP drops" +
                      (s.authenticated ? ", " + std::to_string(s.auth_unsigned + s.auth_bad_mac + s.auth_stale +
                                                               s.auth_replayed) +
                                             " refused by authentication"
                                       : std::string()));
    }
  }
  notifier.stopping("draining the hand-off queue");
  const rec::SessionStats s = session.stop();
  if (!a.quiet || s.outcome != rec::Outcome::kStopped) {
    spdlog::info("{}: {} messages received, {} events written in {} file(s), {} dropped at the hand-off, {} not written "
                 "(writing stopped), {} kernel UDP drops (receive buffer {} bytes); manifest {}",
                 rec::outcome_name(s.outcome), s.received, s.written, s.files.size(), s.dropped_handoff, s.not_written,
                 s.udp_drops, s.udp_rcvbuf_bytes, s.manifest.string());
  }
  const uint64_t refused = s.auth_unsigned + s.auth_bad_mac + s.auth_stale + s.auth_replayed;
  if (s.authenticated && (!a.quiet || refused > 0))
    spdlog::info("authentication refused {} messages (not recorded): {} unsigned, {} bad MAC, {} stale, {} replayed",
                 refused, s.auth_unsigned, s.auth_bad_mac, s.auth_stale, s.auth_replayed);
  if (s.outcome == rec::Outcome::kDiskFull)
    throw pof::IoError("disk full: " + s.error);
  if (s.outcome == rec::Outcome::kIoError) throw pof::IoError("write failed: " + s.error);
  if (s.outcome == rec::Outcome::kFailed) throw pof::IoError(s.error);  // names the file and why
}

}  // namespace

void add_record(CLI::App& app) {
  auto a = std::make_shared<RecordArgs>();
  auto* cmd = app.add_subcommand(
      "record",
      "Record LCM traffic losslessly into crash-safe LCM log files (lcm-logplayer plays them); "
      "--check / --repair inspect and fix logs cut short by a crash or power loss");
  cmd->add_option("-o,--output", a->output,
                  "Log file to create (never overwritten), or an existing directory for a timestamped name");
  cmd->add_option("--lcm-url", a->url,
                  std::string("LCM URL (default $LCM_DEFAULT_URL or ") + pof::bus::kHostOnlyUrl + "); recv_buf_size is added");
  cmd->add_option("-c,--channels", a->channels, "Regex of the channels to record (whole name)")->capture_default_str();
  cmd->add_option("--rotate-mb", a->rotate_mb, "Start a new file before one exceeds this size [MiB] (0: never)")
      ->check(pof::service::non_negative());
  cmd->add_option("--rotate-seconds", a->rotate_seconds, "Start a new file after this long [s] (0: never)")
      ->check(pof::service::non_negative(pof::service::kMaxSeconds));
  cmd->add_option("--duration", a->duration_s, "Stop after this long [s] (0: until SIGINT/SIGTERM)")
      ->check(pof::service::non_negative(pof::service::kMaxSeconds));
  cmd->add_option("--sync-interval", a->sync_interval_s, "fdatasync period [s]: the most a power loss can take")
      ->check(pof::service::positive(pof::service::kMaxSeconds))
      ->capture_default_str();
  cmd->add_option("--queue-capacity", a->queue_capacity, "LCM subscription queue [messages] (LCM's default is 30)")
      ->check(pof::service::positive())
      ->capture_default_str();
  // The recorder reserves the hand-off twice, up front (SessionOptions::handoff_bytes): a bound
  // beyond half this machine's memory can never be allocated, so it is a usage error here, not a
  // bad_alloc at start.
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  const double half_ram_mb = pages > 0 && page > 0 ? std::floor(0.5 * double(pages) * double(page) / (1024.0 * 1024.0)) : 1e6;
  cmd->add_option("--handoff-mb", a->handoff_mb, "Bound of the queue between the LCM and writer threads [MiB]")
      ->check(pof::service::positive(half_ram_mb))
      ->capture_default_str();
  cmd->add_option("--manifest-file", a->manifest_files,
                  "Calibration/configuration file to copy next to the log and list in the manifest (repeatable)");
  cmd->add_flag("-q,--quiet", a->quiet, "Only report problems");
  add_auth_options(cmd, a->auth);
  cmd->add_flag("--liblcm", a->liblcm,
                "Receive udpm:// through liblcm's subscription queue instead of batched recvmmsg "
                "(slower: for comparison)");
  auto* check = cmd->add_option("--check", a->check, "Report complete events, per-channel sequence gaps and any torn tail "
                                                      "of these logs (exit 65 when torn or damaged)");
  auto* repair = cmd->add_option("--repair", a->repair,
                                 "Remove a torn tail (kept as FILE.torn-OFFSET) or rewrite around damage (original kept "
                                 "as FILE.bak)");
  check->excludes(repair);
  cmd->callback([a] {
    if (!a->check.empty()) return run_check(a->check);
    if (!a->repair.empty()) return run_repair(a->repair);
    if (a->output.empty()) throw CLI::RequiredError("--output (or --check/--repair)");
    run_record(*a);
  });
}

}  // namespace pof::cli
