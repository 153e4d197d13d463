// The crash-safe LCM log writer, check and repair (tools/recorder/include/pof/recorder/lcmlog_durable.hpp).
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>
#include <pof/angle_t.hpp>
#include <pof/cycle_stats_t.hpp>
#include <pof/compensator_status_t.hpp>
#include <pof/daq_status_t.hpp>
#include <pof/raw_block_t.hpp>

#include "pof/base/errors.hpp"
#include "pof/bus/channel_filter.hpp"
#include "pof/bus/fingerprint.hpp"
#include "pof/recorder/lcmlog_durable.hpp"
#include "pof/recorder/manifest_state.hpp"
#include "pof/recorder/pof_messages.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace pof::recorder;
using pof::bus::ChannelFilter;

namespace {

using pof::test::TempDir;

std::vector<unsigned char> payload(std::size_t n, unsigned seed) {
  std::vector<unsigned char> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<unsigned char>((i * 31 + seed) & 0xff);
  return v;
}

// Writes `n` events of varying size on two channels; returns the file size.
uint64_t write_events(const fs::path& p, int n) {
  DurableLogWriter w(p, DurableLogWriter::Options{4096});
  for (int i = 0; i < n; ++i) {
    const auto d = payload(static_cast<std::size_t>(10 + (i * 37) % 900), static_cast<unsigned>(i));
    EXPECT_EQ(w.append(1000 + i, i % 3 == 0 ? "POF_ANGLE" : "POF_RAW", d.data(), d.size()), WriteStatus::kOk);
  }
  EXPECT_EQ(w.close(), WriteStatus::kOk);
  return fs::file_size(p);
}

void append_bytes(const fs::path& p, const std::vector<unsigned char>& bytes) {
  std::ofstream f(p, std::ios::binary | std::ios::app);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace

TEST(DurableLogWriter, RoundTripsEventsInTheStandardFormat) {
  TempDir d;
  const fs::path p = d / "a.lcmlog";
  write_events(p, 200);
  LogCheck c;
  const auto ev = read_log(p, &c);
  ASSERT_TRUE(c.clean()) << c.problem;
  ASSERT_EQ(ev.size(), 200u);
  EXPECT_EQ(c.channel_events.at("POF_ANGLE"), 67u);
  for (int i = 0; i < 200; ++i) {
    EXPECT_EQ(ev[static_cast<std::size_t>(i)].event_number, i);
    EXPECT_EQ(ev[static_cast<std::size_t>(i)].utime, 1000 + i);
    EXPECT_EQ(ev[static_cast<std::size_t>(i)].data, payload(static_cast<std::size_t>(10 + (i * 37) % 900), static_cast<unsigned>(i)));
  }
}

TEST(DurableLogWriter, IsReadByLcmsOwnLogReader) {
  // The contract: lcm-logplayer (lcm_eventlog_*) reads what we write.
  TempDir d;
  const fs::path p = d / "a.lcmlog";
  write_events(p, 50);
  lcm::LogFile f(p.string(), "r");
  ASSERT_TRUE(f.good());
  int n = 0;
  while (const lcm::LogEvent* e = f.readNextEvent()) {
    EXPECT_EQ(e->eventnum, n);
    EXPECT_EQ(e->channel, n % 3 == 0 ? "POF_ANGLE" : "POF_RAW");
    EXPECT_EQ(static_cast<std::size_t>(e->datalen), static_cast<std::size_t>(10 + (n * 37) % 900));
    ++n;
  }
  EXPECT_EQ(n, 50);
}

TEST(DurableLogWriter, NeverOverwritesAnExistingFile) {
  TempDir d;
  const fs::path p = d / "a.lcmlog";
  write_events(p, 3);
  EXPECT_THROW(DurableLogWriter w(p), pof::IoError);
  EXPECT_EQ(check_log(p).events, 3u);
}

TEST(CheckLog, FindsATornTailAtEveryCutPoint) {
  // A power loss can cut the file anywhere: every prefix must check as "k complete events + torn
  // tail" with k the number of events wholly inside the prefix.
  TempDir d;
  const fs::path full = d / "full.lcmlog";
  write_events(full, 5);
  std::ifstream in(full, std::ios::binary);
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<uint64_t> ends;
  const auto ev = read_log(full);
  for (std::size_t i = 0; i < ev.size(); ++i)
    ends.push_back(i + 1 < ev.size() ? ev[i + 1].offset : bytes.size());
  for (std::size_t cut = 0; cut <= bytes.size(); cut += 7) {
    const fs::path p = d / ("cut" + std::to_string(cut));
    std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(cut));
    const LogCheck c = check_log(p);
    uint64_t want = 0;
    while (want < ends.size() && ends[want] <= cut) ++want;
    EXPECT_EQ(c.events, want) << "cut at " << cut;
    EXPECT_EQ(c.clean(), want > 0 ? ends[want - 1] == cut : cut == 0) << "cut at " << cut;
    EXPECT_EQ(c.events_after_damage, 0u) << "cut at " << cut;
    fs::remove(p);
  }
}

TEST(RepairLog, TruncatesATornTailAndKeepsTheRemovedBytes) {
  TempDir d;
  const fs::path p = d / "a.lcmlog";
  const uint64_t good = write_events(p, 20);
  // A partial event (header + part of the channel), as a SIGKILL/power loss mid-write leaves.
  std::vector<unsigned char> partial(40, 0);
  put_be32(partial.data(), kLogSync);
  put_be32(partial.data() + 20, 7);
  put_be32(partial.data() + 24, 500);
  append_bytes(p, partial);
  const LogCheck torn = check_log(p);
  EXPECT_FALSE(torn.clean());
  EXPECT_EQ(torn.events, 20u);
  EXPECT_EQ(torn.good_bytes, good);
  EXPECT_EQ(torn.torn_bytes(), 40u);

  const RepairResult r = repair_log(p);
  EXPECT_TRUE(r.changed);
  EXPECT_EQ(fs::file_size(p), good);
  EXPECT_TRUE(check_log(p).clean());
  EXPECT_EQ(check_log(p).events, 20u);
  ASSERT_TRUE(fs::exists(r.backup));
  EXPECT_EQ(fs::file_size(r.backup), 40u);
  // Repairing a clean file changes nothing.
  EXPECT_FALSE(repair_log(p).changed);
}

TEST(RepairLog, ZeroFilledTailFromAPowerLossIsTorn) {
  // ext4 with delayed allocation can leave the file size extended over blocks never written.
  TempDir d;
  const fs::path p = d / "a.lcmlog";
  const uint64_t good = write_events(p, 10);
  append_bytes(p, std::vector<unsigned char>(8192, 0));
  const LogCheck c = check_log(p);
  EXPECT_EQ(c.events, 10u);
  EXPECT_EQ(c.torn_bytes(), 8192u);
  repair_log(p);
  EXPECT_EQ(fs::file_size(p), good);
}

TEST(RepairLog, RewritesAroundDamageInTheMiddleKeepingEveryCompleteEvent) {
  TempDir d;
  const fs::path p = d / "a.lcmlog";
  write_events(p, 30);
  const auto ev = read_log(p);
  {  // Clobber the sync word of event 10.
    std::fstream f(p, std::ios::binary | std::ios::in | std::ios::out);
    f.seekp(static_cast<std::streamoff>(ev[10].offset));
    f.write("JUNK", 4);
  }
  const LogCheck c = check_log(p);
  EXPECT_EQ(c.events, 10u);
  EXPECT_EQ(c.events_after_damage, 19u);
  const RepairResult r = repair_log(p);
  EXPECT_TRUE(r.changed);
  EXPECT_EQ(r.events_kept, 29u);
  LogCheck after;
  const auto ev2 = read_log(p, &after);
  EXPECT_TRUE(after.clean());
  ASSERT_EQ(ev2.size(), 29u);
  EXPECT_EQ(ev2[10].utime, ev[11].utime);  // event 10 is gone, 11 follows 9
  EXPECT_EQ(ev2[10].data, ev[11].data);
  EXPECT_TRUE(fs::exists(r.backup));
  EXPECT_EQ(check_log(r.backup).events, 10u);  // the original, untouched
}

TEST(CheckLog, MissingFileIsNoInput) {
  EXPECT_THROW(check_log("/nonexistent/x.lcmlog"), pof::NoInputError);
}

TEST(DurableLogWriter, FileSizeLimitLeavesOnlyCompleteEvents) {
  // RLIMIT_FSIZE makes write(2) fail with EFBIG exactly like a full disk fails with ENOSPC: a short
  // write, then an error. The writer must undo the partial batch.
  TempDir d;
  const fs::path p = d / "a.lcmlog";
  struct rlimit old {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  auto* prev = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit lim = old;
  lim.rlim_cur = 100000;  // bytes
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &lim), 0);
  WriteStatus st = WriteStatus::kOk;
  uint64_t accepted = 0;
  {
    DurableLogWriter w(p, DurableLogWriter::Options{8192});
    const auto data = payload(333, 1);
    for (int i = 0; i < 1000 && st == WriteStatus::kOk; ++i) {
      st = w.append(i, "POF_RAW", data.data(), data.size());
      if (st == WriteStatus::kOk) ++accepted;
    }
    EXPECT_EQ(st, WriteStatus::kNoSpace);
    EXPECT_EQ(w.error_errno(), EFBIG);
    EXPECT_EQ(w.append(0, "POF_RAW", data.data(), data.size()), WriteStatus::kNoSpace);  // sticky
    EXPECT_LE(w.bytes_written(), 100000u);
    w.close();
    ::setrlimit(RLIMIT_FSIZE, &old);
    std::signal(SIGXFSZ, prev);
    const LogCheck c = check_log(p);
    EXPECT_TRUE(c.clean()) << c.problem;
    EXPECT_EQ(c.events, w.events_written());
    EXPECT_GT(c.events, 200u);  // ~100000 / 368 bytes per event, less the undone batch
    EXPECT_LT(c.events, accepted);
  }
}

TEST(PofMessages, FastSeqMatchesTheGeneratedDecoder) {
  // pof_seq reads seq at a fixed offset; this pins the offset to the .lcm field order.
  auto check = [](const auto& msg, int64_t seq) {
    std::vector<unsigned char> buf(static_cast<std::size_t>(msg.getEncodedSize()));
    ASSERT_GT(msg.encode(buf.data(), 0, static_cast<int>(buf.size())), 0);
    EXPECT_EQ(pof_seq(buf.data(), buf.size()), seq);
    EXPECT_EQ(pof_seq_decoded(buf.data(), buf.size()), seq);
    EXPECT_NE(pof::bus::message_type_of(buf.data(), buf.size()), pof::bus::MessageType::kUnknown);
  };
  pof::raw_block_t r{};
  r.utime = 11;
  r.publish_utime = 12;
  r.seq = 123456789012;
  r.n_channels = 1;
  r.channel_names = {"sensor"};
  r.channel_units = {"V"};
  r.n_scans = 2;
  r.volts = {{1.0f}, {2.0f}};
  check(r, 123456789012);
  pof::angle_t a{};
  a.utime = 1;
  a.publish_utime = 2;
  a.seq = 77;
  check(a, 77);
  pof::cycle_stats_t c{};
  c.utime = 5;
  c.seq = 3;
  check(c, 3);
  pof::daq_status_t s{};
  s.utime = 9;
  s.seq = 42;
  check(s, 42);
  pof::compensator_status_t cs{};
  cs.utime = 10;
  cs.seq = 4242;
  check(cs, 4242);
  const char junk[] = "not ours at all";
  EXPECT_EQ(pof::bus::message_type_of(junk, sizeof junk), pof::bus::MessageType::kUnknown);
  EXPECT_FALSE(pof_seq(junk, sizeof junk).has_value());
}

TEST(SeqTracker, CountsGapsMissingAndRestarts) {
  SeqTracker t;
  for (int64_t s : {0, 1, 2, 5, 6, 10, 0, 1}) t.update(s);
  EXPECT_EQ(t.gaps, 2u);
  EXPECT_EQ(t.missing, 5u);
  EXPECT_EQ(t.restarts, 1u);
  EXPECT_EQ(t.last, 1);
}

TEST(ChannelFilter, WholeNameMatchLikeLcmSubscribe) {
  ChannelFilter f("POF_.*");
  EXPECT_TRUE(f.matches("POF_RAW"));
  EXPECT_TRUE(f.matches("POF_ANGLE_LEFT_KNEE"));
  EXPECT_FALSE(f.matches("XPOF_RAW"));
  EXPECT_TRUE(f.matches("POF_RAW"));  // cached verdict
  ChannelFilter exact("POF_RAW");
  EXPECT_FALSE(exact.matches("POF_RAW_LEFT_KNEE"));
  ChannelFilter alt("POF_(ANGLE|STATS)_\\w+");  // PCRE syntax, as lcm-logger -c accepts
  EXPECT_TRUE(alt.matches("POF_STATS_RIGHT_KNEE"));
  EXPECT_FALSE(alt.matches("POF_RAW_RIGHT_KNEE"));
  EXPECT_THROW(ChannelFilter("(unclosed"), pof::ConfigError);
}

TEST(RepairLog, RefusesAFileARecorderIsStillWriting) {
  TempDir d;
  const fs::path p = d / "live.lcmlog";
  DurableLogWriter w(p);
  const auto data = payload(50, 1);
  w.append(1, "POF_RAW", data.data(), data.size());
  w.flush();
  EXPECT_TRUE(log_is_being_written(p));
  EXPECT_THROW(repair_log(p), pof::IoError);
  w.close();
  EXPECT_FALSE(log_is_being_written(p));
  EXPECT_FALSE(repair_log(p).changed);
}

// A manifest that says "recording" is taken as "interrupted" once its recorder is gone: a killed
// recorder never writes its final status (pof/recorder/manifest_state.hpp).
TEST(ManifestState, ARecordingWhoseRecorderIsGoneIsInterrupted) {
  TempDir d;
  nlohmann::json m = {{"status", "recording"}, {"recorder", this_recorder()}, {"files", nlohmann::json::array()}};
  EXPECT_EQ(manifest_state(m, d.path()).status, "recording") << "this process is alive";
  // A process that has exited (and been reaped): its pid no longer names it.
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  int wst = 0;
  ASSERT_EQ(::waitpid(child, &wst, 0), child);
  m["recorder"]["pid"] = static_cast<long>(child);
  const ManifestState gone = manifest_state(m, d.path());
  EXPECT_EQ(gone.status, "interrupted");
  EXPECT_NE(gone.why.find("is gone"), std::string::npos) << gone.why;
  // The same pid with another start time is another process (pid reuse).
  m["recorder"] = this_recorder();
  m["recorder"]["start_ticks"] = m["recorder"]["start_ticks"].get<std::uint64_t>() + 1;
  EXPECT_EQ(manifest_state(m, d.path()).status, "interrupted");
  m["recorder"] = this_recorder();
  m["recorder"]["boot_id"] = "another-boot";
  EXPECT_NE(manifest_state(m, d.path()).why.find("restarted"), std::string::npos);
  // Another host: cannot be checked from here, so it is left as written.
  m["recorder"] = this_recorder();
  m["recorder"]["host"] = "elsewhere";
  EXPECT_EQ(manifest_state(m, d.path()).status, "recording");
  // A final status is taken as written.
  m["status"] = "stopped";
  EXPECT_EQ(manifest_state(m, d.path()).status, "stopped");
  // A manifest from before "recorder": alive only while a recorder holds one of its log files.
  nlohmann::json old = {{"status", "recording"}, {"files", {{{"name", "s.lcmlog"}}}}};
  {
    DurableLogWriter w(d.path() / "s.lcmlog");
    EXPECT_EQ(manifest_state(old, d.path()).status, "recording");
  }
  EXPECT_EQ(manifest_state(old, d.path()).status, "interrupted");
}

TEST(ManifestState, TheNextRecorderMarksInterruptedManifestsAndFindsTheManifestOfALog) {
  TempDir d;
  const auto write = [&](const std::string& name, const nlohmann::json& m) {
    std::ofstream(d.path() / name) << m.dump(2);
  };
  nlohmann::json dead = {{"status", "recording"}, {"recorder", this_recorder()}, {"files", nlohmann::json::array()}};
  dead["recorder"]["start_ticks"] = 1;  // not this process's start: a recorder that is gone
  write("a.manifest.json", dead);
  write("b.manifest.json", {{"status", "recording"}, {"recorder", this_recorder()}});
  write("c.manifest.json", {{"status", "stopped"}});
  write("d.manifest.json.tmp", dead);  // not a manifest name
  const auto marked = mark_interrupted(d.path());
  ASSERT_EQ(marked.size(), 1U);
  EXPECT_EQ(marked[0].filename(), "a.manifest.json");
  const auto a = nlohmann::json::parse(std::ifstream(d.path() / "a.manifest.json"));
  EXPECT_EQ(a["status"], "interrupted");
  EXPECT_NE(a["interrupted"]["why"].get<std::string>().find("is gone"), std::string::npos);
  EXPECT_TRUE(a["interrupted"].contains("found_utc"));
  EXPECT_EQ(read_manifest_state(d.path() / "b.manifest.json").status, "recording");
  EXPECT_EQ(read_manifest_state(d.path() / "c.manifest.json").status, "stopped");
  EXPECT_TRUE(mark_interrupted(d.path()).empty()) << "marked once";
  // The manifest of a log, rotated or not.
  std::ofstream(d.path() / "a.0003.lcmlog") << "";
  std::ofstream(d.path() / "b.lcmlog") << "";
  EXPECT_EQ(manifest_of_log(d.path() / "a.0003.lcmlog"), d.path() / "a.manifest.json");
  EXPECT_EQ(manifest_of_log(d.path() / "b.lcmlog"), d.path() / "b.manifest.json");
  EXPECT_TRUE(manifest_of_log(d.path() / "x.lcmlog").empty());
}
