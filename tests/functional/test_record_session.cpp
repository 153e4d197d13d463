// The recording session in-process (both receive paths), over udpm on loopback: what liblcm
// publishes ends up in the log, byte for byte and in order, with the manifest's counters agreeing.
// Run under the tsan preset too: the session has a receive thread and a writer thread.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>
#include <pof/angle_t.hpp>

#include "pof/base/errors.hpp"
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
