#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
// UdpmReceiver speaks liblcm's udpm wire protocol: messages published by liblcm itself (short ones
// and fragmented ones of several hundred KB) arrive byte for byte, on loopback multicast (ttl=0).
#include <unistd.h>

#include <chrono>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "lcm_test.hpp"
#include "pof/base/errors.hpp"
#include "pof/bus/udpm_receiver.hpp"

using namespace pof::bus;

namespace {

std::string random_url() { return pof::test::random_udpm_url("ttl=0&recv_buf_size=8388608"); }

struct Got {
  int64_t utime;
  std::string channel;
  std::vector<unsigned char> data;
};

std::vector<Got> receive_until(UdpmReceiver& r, std::size_t n, double timeout_s) {
  std::vector<Got> got;
  const auto t0 = std::chrono::steady_clock::now();
  while (got.size() < n &&
         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < timeout_s) {
    r.receive(50, [&](int64_t t, std::string_view ch, const unsigned char* d, uint32_t s) {
      got.push_back(Got{t, std::string(ch), std::vector<unsigned char>(d, d + s)});
    });
  }
  return got;
}

}  // namespace

// The URL's fields and errors are pof::bus::parse_udpm_url's (tests/unit/test_bus_contract.cpp);
// the receiver turns an error into a ConfigError naming the URL (exit 78).
TEST(UdpmReceiver, RefusesAnInvalidUrlNamingIt) {
  for (const char* bad : {"udpm://10.0.0.1:7667", "udpm://239.255.76.67:99999", "udpm://239.255.76.67:7667?ttl=x", "memq://"}) {
    try {
      UdpmReceiver rx(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const pof::ConfigError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(std::string("LCM URL '") + bad + "': ", 0), 0u) << e.what();
    }
  }
}

TEST(UdpmReceiver, ReceivesShortAndFragmentedMessagesFromLiblcm) {
  const std::string url = random_url();
  UdpmReceiver rx(url);
  lcm::LCM tx(url);
  ASSERT_TRUE(tx.good()) << "no multicast route? " << url;
  std::mt19937 rng(7);
  std::vector<std::vector<unsigned char>> sent;
  std::vector<Got> got;
  // 0 bytes, 1 byte, just below/above liblcm's short-message limit, and fragmented sizes. Each
  // message is received before the next is sent, so that the socket buffer (net.core.rmem_max
  // may cap recv_buf_size) never holds more than one.
  for (std::size_t size : {0u, 1u, 1300u, 1500u, 65000u, 70000u, 300000u, 1000000u}) {
    std::vector<unsigned char> d(size);
    for (auto& b : d) b = static_cast<unsigned char>(rng());
    sent.push_back(d);
    tx.publish("POF_TEST_" + std::to_string(size), d.data(), static_cast<unsigned>(d.size()));
    auto one = receive_until(rx, 1, 5.0);
    ASSERT_EQ(one.size(), 1u) << size << " bytes: malformed " << rx.malformed() << " incomplete "
                              << rx.incomplete_messages();
    got.push_back(std::move(one.front()));
  }
  ASSERT_EQ(got.size(), sent.size()) << "malformed " << rx.malformed() << " incomplete " << rx.incomplete_messages();
  for (std::size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(got[i].channel, "POF_TEST_" + std::to_string(sent[i].size()));
    EXPECT_EQ(got[i].data, sent[i]) << "message " << i;
    EXPECT_GT(got[i].utime, 1'600'000'000'000'000);  // a kernel timestamp, us since the epoch
  }
  EXPECT_EQ(rx.malformed(), 0u);
  EXPECT_EQ(rx.incomplete_messages(), 0u);
}

TEST(UdpmReceiver, CoexistsWithALiblcmSubscriberOnTheSamePort) {
  // SO_REUSEADDR as liblcm does: a recorder must not steal the bus from the daemons.
  const std::string url = random_url();
  UdpmReceiver rx(url);
  lcm::LCM sub(url);
  ASSERT_TRUE(sub.good());
  int seen = 0;
  sub.subscribeFunction("POF_X", +[](const lcm::ReceiveBuffer*, const std::string&, int* n) { ++*n; }, &seen);
  lcm::LCM tx(url);
  const char msg[] = "hello";
  tx.publish("POF_X", msg, sizeof msg);
  const auto got = receive_until(rx, 1, 2.0);
  ASSERT_EQ(got.size(), 1u) << got.front().channel << " " << got.back().channel;  // not LCM_SELF_TEST
  sub.handleTimeout(1000);
  EXPECT_EQ(seen, 1);
}

TEST(UdpmReceiver, IgnoresGarbageDatagrams) {
  const std::string url = random_url();
  const UdpmUrl u = parse_udpm_url(url);
  UdpmReceiver rx(url);
  // Send raw datagrams with liblcm's transmit socket semantics replaced by a plain socket.
  const int s = ::socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(s, 0);
  unsigned char ttl = 0;
  ::setsockopt(s, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(u.port);
  inet_aton(u.group.c_str(), &to.sin_addr);
  const unsigned char junk1[] = {1, 2, 3};
  const unsigned char junk2[] = {0x4C, 0x43, 0x30, 0x32, 0, 0, 0, 1, 'N', 'O', 'N', 'U', 'L'};  // LC02, no '\0'
  const unsigned char junk3[] = {0x4C, 0x43, 0x30, 0x33, 0, 0, 0, 1, 0, 0};                  // LC03, short
  for (const auto& [p, n] : {std::pair{junk1, sizeof junk1}, {junk2, sizeof junk2}, {junk3, sizeof junk3}})
    ::sendto(s, p, n, 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  ::close(s);
  lcm::LCM tx(url);
  const char ok[] = "ok";
  tx.publish("POF_OK", ok, sizeof ok);
  const auto got = receive_until(rx, 1, 2.0);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].channel, "POF_OK");
  EXPECT_EQ(rx.malformed(), 3u);
}
