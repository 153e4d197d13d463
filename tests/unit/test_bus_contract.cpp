// The bus contract (common/bus/include/pof/bus/): which LCM URL a process uses, what a udpm:// URL says,
// the channel names and their inverse, and our types by fingerprint.
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "pof/bus/channels.hpp"
#include "pof/bus/fingerprint.hpp"
#include "pof/bus/url.hpp"

namespace {

using pof::bus::Stream;

// $LCM_DEFAULT_URL for the scope of one test (nullptr: unset), restored afterwards.
class EnvUrl {
 public:
  explicit EnvUrl(const char* value) {
    if (const char* old = std::getenv("LCM_DEFAULT_URL")) old_ = old;
    if (value != nullptr) ::setenv("LCM_DEFAULT_URL", value, 1);
    else ::unsetenv("LCM_DEFAULT_URL");
  }
  ~EnvUrl() {
    if (old_) ::setenv("LCM_DEFAULT_URL", old_->c_str(), 1);
    else ::unsetenv("LCM_DEFAULT_URL");
  }
  EnvUrl(const EnvUrl&) = delete;
  EnvUrl& operator=(const EnvUrl&) = delete;

 private:
  std::optional<std::string> old_;
};

template <class T>
std::vector<unsigned char> encode(const T& m) {
  std::vector<unsigned char> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

}  // namespace

TEST(BusUrl, TheOptionWinsThenTheEnvironmentThenThisHostOnly) {
  using pof::bus::resolve_url;
  {
    const EnvUrl env("udpm://239.255.76.68:7001?ttl=1");
    EXPECT_EQ(resolve_url("udpm://239.255.76.69:7002?ttl=0"), "udpm://239.255.76.69:7002?ttl=0&recv_buf_size=8388608");
    EXPECT_EQ(resolve_url(""), "udpm://239.255.76.68:7001?ttl=1&recv_buf_size=8388608");
    EXPECT_EQ(resolve_url("memq://"), "memq://");  // not udpm: nothing added
  }
  {
    const EnvUrl env(nullptr);
    EXPECT_EQ(resolve_url(""), std::string(pof::bus::kHostOnlyUrl) + "&recv_buf_size=8388608");
  }
  {
    const EnvUrl env("");  // set but empty, as an EnvironmentFile line "LCM_DEFAULT_URL=" leaves it
    EXPECT_EQ(resolve_url(""), std::string(pof::bus::kHostOnlyUrl) + "&recv_buf_size=8388608");
  }
}

TEST(BusUrl, ReceiveBufferIsAddedOnlyWhereMissing) {
  using pof::bus::resolve_url;
  EXPECT_EQ(resolve_url("udpm://239.255.76.67:7667"), "udpm://239.255.76.67:7667?recv_buf_size=8388608");
  EXPECT_EQ(resolve_url("udpm://239.255.76.67:7667?recv_buf_size=1000"), "udpm://239.255.76.67:7667?recv_buf_size=1000");
  EXPECT_EQ(resolve_url("udpm://239.255.76.67:7667?ttl=0", 4096), "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4096");
  EXPECT_EQ(resolve_url("file:///tmp/x.lcmlog?mode=w"), "file:///tmp/x.lcmlog?mode=w");
}

TEST(BusUrl, ParsesLiblcmSyntax) {
  const auto u = pof::bus::parse_udpm_url("udpm://239.255.76.68:7700?ttl=1&recv_buf_size=4194304&transmit_only=true");
  EXPECT_TRUE(u.ok()) << u.error;
  EXPECT_EQ(u.group, "239.255.76.68");
  EXPECT_EQ(u.port, 7700);
  EXPECT_EQ(u.ttl, 1);
  EXPECT_EQ(u.recv_buf_size, 4194304);
  const auto d = pof::bus::parse_udpm_url("udpm://");
  EXPECT_TRUE(d.ok());
  EXPECT_EQ(d.group, "239.255.76.67");
  EXPECT_EQ(d.port, 7667);
  EXPECT_EQ(d.ttl, 0);
  EXPECT_EQ(d.recv_buf_size, 0);
  EXPECT_EQ(pof::bus::parse_udpm_url("udpm://239.255.76.67?ttl=2&ttl=3").ttl, 3);  // the last one counts
  EXPECT_EQ(pof::bus::parse_udpm_url("udpm://224.0.0.1:1").port, 1);
}

TEST(BusUrl, SaysWhatIsWrong) {
  const auto error = [](const char* url) { return pof::bus::parse_udpm_url(url).error; };
  EXPECT_EQ(error("memq://"), "not a udpm:// URL");
  EXPECT_EQ(error("UDPM://239.255.76.67:7667"), "not a udpm:// URL");
  EXPECT_EQ(error("udpm://10.0.0.1:7667"), "'10.0.0.1' is not an IPv4 multicast address");
  EXPECT_EQ(error("udpm://:7667"), "'' is not an IPv4 multicast address");
  EXPECT_EQ(error("udpm://240.0.0.1:7667"), "'240.0.0.1' is not an IPv4 multicast address");
  for (const char* port : {"", "0", "65536", "99999", "+80", " 80", "80x", "7667:1"})
    EXPECT_EQ(error((std::string("udpm://239.255.76.67:") + port).c_str()), "port: expected 1..65535") << port;
  for (const char* ttl : {"", "x", "256", "-1", "1_0", "0x1"})
    EXPECT_EQ(error((std::string("udpm://239.255.76.67:7667?ttl=") + ttl).c_str()), "ttl: expected 0..255") << ttl;
  EXPECT_EQ(error("udpm://239.255.76.67:7667?ttl"), "ttl: expected 0..255");
  EXPECT_EQ(error("udpm://239.255.76.67:7667?recv_buf_size=1073741825"), "recv_buf_size: expected 0..1073741824 bytes");
}

TEST(BusChannels, EveryStreamWithAndWithoutSensorId) {
  EXPECT_EQ(pof::bus::channel(Stream::kRaw), "POF_RAW");
  EXPECT_EQ(pof::bus::channel(Stream::kDaqStatus, "LEFT_KNEE"), "POF_DAQ_STATUS_LEFT_KNEE");
  EXPECT_EQ(pof::bus::channel(Stream::kAngle, "LEFT_KNEE"), "POF_ANGLE_LEFT_KNEE");
  EXPECT_EQ(pof::bus::channel(Stream::kStats, ""), "POF_STATS");
  EXPECT_EQ(pof::bus::channel(Stream::kCompensatorStatus, "EXO2_RIGHT_KNEE"), "POF_COMPENSATOR_STATUS_EXO2_RIGHT_KNEE");
}

TEST(BusChannels, ParseIsTheInverseOfChannel) {
  for (const Stream s : pof::bus::kStreams) {
    // Ids that end like, or are, another stream's name must not confuse the parse.
    for (const char* id : {"", "LEFT_KNEE", "RAW", "STATUS", "DAQ_STATUS_X", "_", "1"}) {
      const auto p = pof::bus::parse_channel(pof::bus::channel(s, id));
      ASSERT_TRUE(p.has_value()) << pof::bus::channel(s, id);
      EXPECT_EQ(p->stream, s) << pof::bus::channel(s, id);
      EXPECT_EQ(p->sensor_id, id) << pof::bus::channel(s, id);
    }
  }
  for (const char* foreign : {"POF_RAWX", "POF_RAW_", "POF_ANGLES", "POF_STATUS", "POF_DAQ", "FOREIGN_TELEMETRY", "",
                              "pof_raw", "XPOF_RAW"})
    EXPECT_FALSE(pof::bus::parse_channel(foreign).has_value()) << foreign;
}

TEST(BusFingerprint, NamesEveryTypeOfOursAndNothingElse) {
  using pof::bus::MessageType;
  const auto type_of = [](const std::vector<unsigned char>& b) { return pof::bus::message_type_of(b.data(), b.size()); };
  EXPECT_EQ(type_of(encode(pof::raw_block_t{})), MessageType::kRawBlock);
  EXPECT_EQ(type_of(encode(pof::angle_t{})), MessageType::kAngle);
  EXPECT_EQ(type_of(encode(pof::cycle_stats_t{})), MessageType::kCycleStats);
  EXPECT_EQ(type_of(encode(pof::daq_status_t{})), MessageType::kDaqStatus);
  EXPECT_EQ(type_of(encode(pof::compensator_status_t{})), MessageType::kCompensatorStatus);
  const std::vector<unsigned char> angle = encode(pof::angle_t{});
  EXPECT_EQ(pof::bus::fingerprint_of(angle.data(), angle.size()), static_cast<std::uint64_t>(pof::angle_t::getHash()));
  EXPECT_EQ(pof::bus::message_type_of(angle.data(), 7), MessageType::kUnknown);  // shorter than a fingerprint
  EXPECT_EQ(pof::bus::fingerprint_of(angle.data(), 7), 0u);
  const unsigned char foreign[] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  EXPECT_EQ(pof::bus::message_type_of(foreign, sizeof foreign), MessageType::kUnknown);
  EXPECT_STREQ(pof::bus::message_type_name(MessageType::kDaqStatus), "daq_status_t");
  EXPECT_STREQ(pof::bus::message_type_name(MessageType::kUnknown), "?");
}

// A sensor id suffixes every channel: upper case, digits and '_', and short enough that the
// longest channel fits LCM's 63 characters (a longer one was taken, then every publish refused).
TEST(BusChannels, SensorIdsThatFitLcmsChannelNames) {
  using pof::bus::sensor_id_problem;
  EXPECT_EQ(sensor_id_problem(""), "");
  EXPECT_EQ(sensor_id_problem("LEFT_KNEE"), "");
  EXPECT_EQ(pof::bus::kMaxSensorIdChars, 40u);
  const std::string longest(pof::bus::kMaxSensorIdChars, 'K');
  EXPECT_EQ(sensor_id_problem(longest), "");
  EXPECT_EQ(pof::bus::channel(pof::bus::Stream::kCompensatorStatus, longest).size(), pof::bus::kMaxChannelChars);
  EXPECT_NE(sensor_id_problem(longest + "K"), "");
  for (const char* bad : {"left_knee", "LEFT-KNEE", "LEFT.*", "LEFT KNEE"}) EXPECT_NE(sensor_id_problem(bad), "") << bad;
}
