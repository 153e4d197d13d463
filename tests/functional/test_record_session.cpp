// The recording session in-process (both receive paths), over udpm on loopback: what liblcm
// publishes ends up in the log, byte for byte and in order, with the manifest's counters agreeing;
// in the authenticated mode only what passes verification does.
// Run under the tsan preset too: the session has a receive thread and a writer thread.
#include <sys/resource.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>
#include <pof/angle_t.hpp>

#include "pof/base/errors.hpp"
#include "pof/bus/auth.hpp"
#include "pof/bus/publisher.hpp"
#include "pof/recorder/lcmlog_durable.hpp"
#include "pof/recorder/session.hpp"
#include "lcm_test.hpp"
#include "poll.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace pof::recorder;

namespace {

using pof::test::TempDir;

using pof::test::random_udpm_url;

// Polls the session's counters (they have no condition to wait on) until `n` selected messages
// were received; false after 10 s.
bool wait_received(Session& s, uint64_t n) {
  return pof::test::poll_until([&] { return s.poll().received >= n; });
}

void record_and_check(bool liblcm) {
  TempDir d;
  SessionOptions o;
  o.lcm_url = random_udpm_url();
  o.output = d.path() / "s.lcmlog";
  o.channels = "POF_ANGLE.*";
  o.use_liblcm = liblcm;
  o.rotate_bytes = 64 * 1024;  // several files
  Session s(o);
  s.start();
  lcm::LCM tx(o.lcm_url);
  ASSERT_TRUE(tx.good());
  constexpr int kN = 5000;
  pof::angle_t a{};
  for (int i = 0; i < kN; ++i) {
    a.seq = i;
    a.angle_deg = static_cast<float>(i);
    tx.publish("POF_ANGLE_LEFT_KNEE", &a);
    tx.publish("OTHER", &a);  // not selected
    // Flow control: the socket buffer (net.core.rmem_max may cap it) holds a few thousand
    // datagrams, so let the session catch up every 500 messages (1000 datagrams).
    if (i % 500 == 499) {
      ASSERT_TRUE(wait_received(s, static_cast<uint64_t>(i + 1))) << s.poll().received;
    }
  }
  ASSERT_TRUE(wait_received(s, kN)) << s.poll().received;
  const SessionStats st = s.stop();
  EXPECT_EQ(st.outcome, Outcome::kStopped);
  EXPECT_EQ(st.received, static_cast<uint64_t>(kN));
  EXPECT_EQ(st.written, static_cast<uint64_t>(kN));
  EXPECT_EQ(st.dropped_handoff, 0u);
  ASSERT_GE(st.files.size(), 2u);

  int64_t next = 0;
  for (const auto& f : st.files) {
    LogCheck c;
    const auto events = read_log(f, &c);
    EXPECT_TRUE(c.clean()) << f;
    for (const auto& e : events) {
      EXPECT_EQ(e.channel, "POF_ANGLE_LEFT_KNEE");
      pof::angle_t got{};
      ASSERT_GT(got.decode(e.data.data(), 0, static_cast<int>(e.data.size())), 0);
      EXPECT_EQ(got.seq, next);
      EXPECT_EQ(got.angle_deg, static_cast<float>(next));
      ++next;
    }
    EXPECT_LE(fs::file_size(f), 64u * 1024u) << f;
  }
  EXPECT_EQ(next, kN);

  const auto m = nlohmann::json::parse(std::ifstream(st.manifest));
  EXPECT_EQ(m["status"], "stopped");
  EXPECT_EQ(m["receiver"], liblcm ? "liblcm" : "recvmmsg");
  EXPECT_EQ(m["counters"]["written"], kN);
  EXPECT_EQ(m["channels"]["POF_ANGLE_LEFT_KNEE"]["seq"]["gaps"], 0);
  EXPECT_EQ(m["channels"]["POF_ANGLE_LEFT_KNEE"]["type"], "angle_t");
  EXPECT_EQ(m["files"].size(), st.files.size());
}

}  // namespace

TEST(RecordSession, RecvmmsgPathRecordsEverySelectedMessageInOrder) { record_and_check(false); }
TEST(RecordSession, LiblcmPathRecordsEverySelectedMessageInOrder) { record_and_check(true); }

// A full disk mid-recording (RLIMIT_FSIZE: write(2) fails with EFBIG exactly as a full file system
// fails with ENOSPC, and needs no mount): every message the session received is either in the log
// or counted, with the reason, and the per-channel counts are of what the log holds
// (docs/deployment.md, "pof record").
TEST(RecordSession, DiskFullLosesNoMessageSilently) {
  TempDir d;
  SessionOptions o;
  o.lcm_url = random_udpm_url();
  o.output = d.path() / "full.lcmlog";
  o.channels = "POF_ANGLE.*";
  o.sync_interval_s = 0.05;
  struct rlimit old {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  auto* prev = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit lim = old;
  lim.rlim_cur = 48 * 1024;  // bytes: ~350 events of this test
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &lim), 0);
  Session s(o);
  s.start();
  lcm::LCM tx(o.lcm_url);
  ASSERT_TRUE(tx.good());
  constexpr int kN = 3000;
  pof::angle_t a{};
  for (int i = 0; i < kN; ++i) {
    a.seq = i;
    tx.publish("POF_ANGLE_LEFT_KNEE", &a);
    // Batches of 100 with flow control: the writer meets the limit inside a batch, with events of
    // it already appended and more behind it in the hand-off queue.
    if (i % 100 == 99) {
      ASSERT_TRUE(wait_received(s, static_cast<uint64_t>(i + 1))) << s.poll().received;
    }
    // The first batch on disk before the limit comes near: a writer slowed down (ASan) would
    // otherwise take 350+ events into its first write, which the limit refuses whole (nothing
    // recorded: the 'failed' outcome, a different test).
    if (i == 99) {
      ASSERT_TRUE(pof::test::poll_until([&] { return s.poll().written >= 100; })) << s.poll().written;
    }
  }
  ASSERT_TRUE(wait_received(s, kN)) << s.poll().received;
  const SessionStats st = s.stop();
  ::setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, prev);
  EXPECT_EQ(st.outcome, Outcome::kDiskFull);
  ASSERT_EQ(st.received, static_cast<uint64_t>(kN));

  uint64_t in_files = 0;
  for (const auto& f : st.files) {
    LogCheck c;
    in_files += read_log(f, &c).size();
    EXPECT_TRUE(c.clean()) << f;
  }
  EXPECT_EQ(in_files, st.written);
  EXPECT_GT(st.written, 100u);
  EXPECT_LT(st.written, static_cast<uint64_t>(kN));

  const auto m = nlohmann::json::parse(std::ifstream(st.manifest));
  const auto& c = m["counters"];
  const uint64_t not_written = c.value("not_written", uint64_t{0});
  EXPECT_EQ(c["received"].get<uint64_t>(),
            c["written"].get<uint64_t>() + c["dropped_handoff"].get<uint64_t>() + not_written)
      << c.dump();
  EXPECT_EQ(c["written"].get<uint64_t>(), in_files);
  EXPECT_GT(not_written, 0u);
  EXPECT_NE(c.value("not_written_reason", std::string()).find("File too large"), std::string::npos) << c.dump();
  EXPECT_EQ(m["channels"]["POF_ANGLE_LEFT_KNEE"]["events"].get<uint64_t>(), in_files) << m["channels"].dump();
  uint64_t file_events = 0;
  for (const auto& f : m["files"]) file_events += f["events"].get<uint64_t>();
  EXPECT_EQ(file_events, in_files);
}

TEST(RecordSession, SetupErrorsNameTheProblem) {
  TempDir d;
  SessionOptions o;
  o.lcm_url = random_udpm_url();
  o.output = d.path() / "x.lcmlog";
  o.channels = "(";
  EXPECT_THROW(Session{o}, pof::ConfigError);
  o.channels = ".*";
  o.manifest_files = {d.path() / "missing.toml"};
  EXPECT_THROW(Session{o}, pof::NoInputError);
  o.manifest_files.clear();
  o.output = d.path() / "no-such-dir" / "x.lcmlog";
  EXPECT_THROW(Session{o}, pof::IoError);
  o.output = d.path() / "x.lcmlog";
  o.lcm_url = "udpm://10.1.2.3:7667";  // not a multicast group
  Session bad(o);
  EXPECT_THROW(bad.start(), pof::ConfigError);
}

// The authenticated mode (both receive paths): only verified messages are recorded, without their
// trailers; unsigned, forged and replayed ones are counted in the manifest and not recorded.
void record_authenticated(bool liblcm) {
  TempDir d;
  std::vector<unsigned char> kb(pof::bus::auth::Key::kBytes, 0x33), other(pof::bus::auth::Key::kBytes, 0x44);
  const auto key = std::make_shared<const pof::bus::auth::Key>(kb.data(), kb.size());
  SessionOptions o;
  o.lcm_url = random_udpm_url();
  o.output = d.path() / "a.lcmlog";
  o.channels = "POF_.*";  // not liblcm's LCM_SELF_TEST probe (unsigned), which its own receiver passes on
  o.use_liblcm = liblcm;
  o.auth_key = key;
  Session s(o);
  s.start();
  lcm::LCM tx(o.lcm_url);
  ASSERT_TRUE(tx.good());
  // A tap that keeps the first signed message's bytes, to replay them.
  std::vector<unsigned char> first;
  lcm::Subscription* tap = tx.subscribeFunction(
      "POF_ANGLE", +[](const lcm::ReceiveBuffer* rb, const std::string&, std::vector<unsigned char>* out) {
        if (out->empty()) out->assign(static_cast<const unsigned char*>(rb->data),
                                      static_cast<const unsigned char*>(rb->data) + rb->data_size);
      }, &first);
  pof::bus::Publisher pub(tx, key), forger(tx, std::make_shared<const pof::bus::auth::Key>(other.data(), other.size()));
  pof::angle_t a{};
  for (int i = 0; i < 3; ++i) {
    a.seq = i;
    ASSERT_EQ(pub.publish("POF_ANGLE", a), 0);
  }
  ASSERT_TRUE(wait_received(s, 3)) << s.poll().received;
  ASSERT_TRUE(pof::test::poll_until([&] {
    tx.handleTimeout(20);
    return !first.empty();
  }));
  tx.unsubscribe(tap);
  a.seq = 100;
  tx.publish("POF_ANGLE", &a);                                                  // unsigned
  ASSERT_EQ(forger.publish("POF_ANGLE", a), 0);                                 // another key
  tx.publish("POF_ANGLE", first.data(), static_cast<unsigned>(first.size()));  // replayed
  a.seq = 3;
  ASSERT_EQ(pub.publish("POF_ANGLE", a), 0);
  ASSERT_TRUE(wait_received(s, 4)) << s.poll().received;
  ASSERT_TRUE(pof::test::poll_until([&] { return s.poll().auth_replayed >= 1; }));
  const SessionStats st = s.stop();
  EXPECT_TRUE(st.authenticated);
  EXPECT_EQ(st.written, 4u);
  EXPECT_EQ(st.auth_unsigned, 1u);
  EXPECT_EQ(st.auth_bad_mac, 1u);
  EXPECT_EQ(st.auth_replayed, 1u);
  EXPECT_EQ(st.auth_stale, 0u);
  const auto events = read_log(st.files.at(0));
  ASSERT_EQ(events.size(), 4u);
  for (std::size_t i = 0; i < events.size(); ++i) {
    a.seq = static_cast<int64_t>(i);
    EXPECT_EQ(events[i].data, pof::test::encode(a)) << i;  // the LCM message as published, no trailer
  }
  const auto m = nlohmann::json::parse(std::ifstream(st.manifest));
  EXPECT_EQ(m["authentication"]["enabled"], true);
  EXPECT_EQ(m["authentication"]["key_id"], pof::bus::auth::key_id_hex(key->id()));
  EXPECT_EQ(m["authentication"]["dropped"]["unsigned"], 1);
  EXPECT_EQ(m["authentication"]["dropped"]["bad_mac"], 1);
  EXPECT_EQ(m["authentication"]["dropped"]["replayed"], 1);
  EXPECT_EQ(m["channels"]["POF_ANGLE"]["seq"]["gaps"], 0);
}

TEST(RecordSession, AuthenticatedRecvmmsgPathRecordsOnlyVerifiedMessages) { record_authenticated(false); }
TEST(RecordSession, AuthenticatedLiblcmPathRecordsOnlyVerifiedMessages) { record_authenticated(true); }

// A flood of distinct channel names (any local process can publish them): every message is in the
// log, but the manifest keeps a row for at most kMaxTrackedChannels names (POF_* names a reserve
// beyond it) and counts the rest in "other_channels", so its size no longer follows the flood.
TEST(RecordSession, ManyDistinctChannelsAreAllRecordedButTrackedOnlyUpToTheBound) {
  TempDir d;
  SessionOptions o;
  o.lcm_url = random_udpm_url();
  o.output = d.path() / "flood.lcmlog";
  o.channels = "FLOOD_.*|POF_.*";  // not liblcm's LCM_SELF_TEST probe
  Session s(o);
  s.start();
  lcm::LCM tx(o.lcm_url);
  ASSERT_TRUE(tx.good());
  constexpr uint64_t kFlood = 3000;
  pof::angle_t a{};
  const std::size_t size = pof::test::encode(a).size();
  for (uint64_t i = 0; i < kFlood; ++i) {
    tx.publish("FLOOD_" + std::to_string(i), &a);
    if (i % 500 == 499) {  // flow control
      ASSERT_TRUE(wait_received(s, i + 1)) << s.poll().received;
    }
  }
  for (int i = 0; i < 3; ++i) {
    a.seq = i;
    tx.publish("POF_ANGLE_LEFT_KNEE", &a);  // after the flood: still tracked
  }
  ASSERT_TRUE(wait_received(s, kFlood + 3)) << s.poll().received;
  const SessionStats st = s.stop();
  EXPECT_EQ(st.written, kFlood + 3);
  std::size_t logged = 0;
  for (const auto& f : st.files) logged += read_log(f).size();
  EXPECT_EQ(logged, kFlood + 3) << "every message is recorded, tracked or not";
  const auto m = nlohmann::json::parse(std::ifstream(st.manifest));
  EXPECT_EQ(m["channels"].size(), kMaxTrackedChannels + 1);
  EXPECT_EQ(m["channels"]["POF_ANGLE_LEFT_KNEE"]["events"], 3);
  EXPECT_EQ(m["channels"]["POF_ANGLE_LEFT_KNEE"]["seq"]["gaps"], 0);
  EXPECT_EQ(m["other_channels"]["events"], kFlood - kMaxTrackedChannels);
  EXPECT_EQ(m["other_channels"]["bytes"], (kFlood - kMaxTrackedChannels) * size);
  EXPECT_EQ(m["other_channels"]["tracked_limit"], kMaxTrackedChannels);
  EXPECT_EQ(m["other_channels"]["examples"].size(), kOtherExamples);
  EXPECT_EQ(m["counters"]["written"], kFlood + 3);
  // The manifest stays small: ~150 bytes per tracked row, whatever the number of names.
  EXPECT_LT(fs::file_size(st.manifest), 400u * 1024u);
}
