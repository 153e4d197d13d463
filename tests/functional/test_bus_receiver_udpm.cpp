// pof::bus::Receiver over udpm:// (our socket, real multicast on loopback; ctest label `network`):
// malformed datagrams, impossible fragments and a horde of senders are counted and bounded;
// unicast to the host's address is not received; the authenticated mode over real multicast. The
// memq:// path is test_bus_receiver.cpp (and test_bus_auth.cpp for the authenticated mode).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "bus_receiver_test.hpp"
#include "lcm_test.hpp"
#include "pof/angle_t.hpp"
#include "pof/bus/auth.hpp"
#include "pof/bus/publisher.hpp"
#include "pof/bus/receiver.hpp"
#include "pof/base/errors.hpp"
#include "pof/raw_block_t.hpp"
#include "udpm_wire.hpp"

namespace {

using pof::bus::Delivery;
using pof::bus::Receiver;
using pof::test::encode;

std::string random_url() { return pof::test::random_udpm_url("ttl=0&recv_buf_size=8388608"); }

using pof::test::handle_until;
pof::angle_t angle(std::int64_t seq) { return pof::test::numbered_angle(seq); }

// A plain UDP socket for hand-made datagrams (what an attacker on the host or LAN can send).
struct RawSender {
  int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  RawSender() {
    unsigned char ttl = 0;
    ::setsockopt(fd, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
  }
  ~RawSender() { ::close(fd); }
  void send(const std::string& addr, uint16_t port, const std::vector<unsigned char>& d) const {
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(port);
    inet_aton(addr.c_str(), &to.sin_addr);
    ::sendto(fd, d.data(), d.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  }
};

using pof::test::udpm_short;
// A fragment of `body_bytes` bytes 0xAB; fragment 0 carries the channel POF_RAW.
std::vector<unsigned char> fragment(uint32_t seq, uint32_t size, uint32_t offset, uint16_t no, uint16_t count,
                                    std::size_t body_bytes) {
  return pof::test::udpm_fragment(seq, size, offset, no, count, no == 0 ? "POF_RAW" : "",
                                  std::vector<unsigned char>(body_bytes, 0xAB));
}

}  // namespace

TEST(BusReceiver, UdpmUnicastToTheHostIsNotReceived) {
  const std::string url = random_url();
  const auto u = pof::bus::parse_udpm_url(url);
  lcm::LCM lc(url);
  Receiver rx(lc, url);
  ASSERT_TRUE(rx.direct());
  std::vector<std::int64_t> got;
  rx.subscribe<pof::angle_t>("POF_ANGLE", [&](const pof::angle_t& a, const Delivery&) { got.push_back(a.seq); });
  RawSender s;
  s.send("127.0.0.1", u.port, udpm_short(1, "POF_ANGLE", encode(angle(666))));  // unicast first
  s.send(u.group, u.port, udpm_short(2, "POF_ANGLE", encode(angle(7))));        // then the group
  handle_until(rx, [&] { return !got.empty(); });
  rx.handle(50);
  EXPECT_EQ(got, (std::vector<std::int64_t>{7}));
  EXPECT_EQ(rx.stats().datagrams, 1u);
}

TEST(BusReceiver, UdpmHostileDatagramsAreCountedAndReassemblyIsBounded) {
  const std::string url = random_url();
  const auto u = pof::bus::parse_udpm_url(url);
  lcm::LCM lc(url);
  Receiver rx(lc, url);
  std::vector<std::int64_t> got;
  rx.subscribe<pof::raw_block_t>("POF_RAW", [&](const pof::raw_block_t& b, const Delivery&) { got.push_back(b.seq); });
  RawSender s;
  std::uint64_t want_malformed = 0;
  // The fragment that crashes liblcm 1.3.1: offset 0xFFFFFFFF.
  s.send(u.group, u.port, fragment(1, 100000, 0xFFFFFFFFu, 1, 2, 1000));
  ++want_malformed;
  // Messages beyond the 16 MiB limit, a fragment number beyond the count, a count of 0.
  s.send(u.group, u.port, fragment(2, 0xFFFFFFFFu, 0, 0, 65535, 1000));
  s.send(u.group, u.port, fragment(3, (16u << 20) + 1, 0, 1, 300, 1000));
  s.send(u.group, u.port, fragment(4, 100000, 0, 5, 2, 1000));
  s.send(u.group, u.port, fragment(5, 100000, 0, 1, 0, 1000));
  want_malformed += 4;
  // Two fragments whose counts and byte total are right but which overlap and leave a hole: the
  // bytes 100-199 no fragment wrote must not be delivered.
  s.send(u.group, u.port, fragment(8, 200 + 8, 0, 0, 2, 100));
  s.send(u.group, u.port, fragment(8, 200 + 8, 0, 1, 2, 108));
  ++want_malformed;
  // Garbage and short junk.
  for (int i = 0; i < 100; ++i) s.send(u.group, u.port, std::vector<unsigned char>(static_cast<std::size_t>(1 + i), 0x5A));
  want_malformed += 100;
  // 200 senders (source ports) each opening a 16 MiB message and never finishing it.
  {
    std::vector<RawSender> horde(200);
    for (auto& h : horde) h.send(u.group, u.port, fragment(6, 16u << 20, 1000, 1, 256, 1000));
  }
  // A raw_block_t whose n_scans is 2^31-1 (the 70-byte datagram of the bad_alloc).
  pof::raw_block_t bomb{};
  auto bytes = encode(bomb);
  const std::size_t n_scans_at = bytes.size() - 8;  // n_scans then flags, with no channels or scans
  for (int i = 0; i < 4; ++i) bytes[n_scans_at + static_cast<std::size_t>(i)] = i == 0 ? 0x7f : 0xff;
  s.send(u.group, u.port, udpm_short(7, "POF_RAW", bytes));
  // And then a good one, fragmented, from liblcm.
  pof::raw_block_t good{};
  good.seq = 42;
  good.n_channels = 1;
  good.channel_names = {"sensor"};
  good.channel_units = {"V"};
  good.n_scans = 30000;  // 120 KB: fragmented
  good.volts.assign(30000, std::vector<float>{1.0f});
  ASSERT_EQ(lc.publish("POF_RAW", &good), 0);
  handle_until(rx, [&] { return !got.empty(); });

  EXPECT_EQ(got, (std::vector<std::int64_t>{42}));
  const auto st = rx.stats();
  EXPECT_EQ(st.malformed_datagrams, want_malformed);
  EXPECT_EQ(rx.channel_stats("POF_RAW").decode_errors, 1u);
  // 200 partial messages, at most 64 tracked and their declared sizes within 64 MiB.
  EXPECT_GE(st.incomplete_messages, 200u - 64u);
  EXPECT_LE(st.incomplete_messages, 200u);
}

TEST(BusReceiver, UdpmAuthenticatedVerifiesWhatIsSubscribedOnlyAlsoFragmented) {
  const std::string url = random_url();
  const auto u = pof::bus::parse_udpm_url(url);
  lcm::LCM lc(url);
  std::vector<unsigned char> kb(pof::bus::auth::Key::kBytes, 0x5a);
  const auto key = std::make_shared<const pof::bus::auth::Key>(kb.data(), kb.size());
  pof::bus::ReceiverOptions ro;
  ro.auth_key = key;
  Receiver rx(lc, url, ro);
  ASSERT_TRUE(rx.direct());
  std::vector<std::int64_t> angles;
  std::vector<std::int32_t> blocks;
  rx.subscribe<pof::angle_t>("POF_ANGLE", [&](const pof::angle_t& a, const Delivery&) { angles.push_back(a.seq); });
  rx.subscribe<pof::raw_block_t>("POF_RAW", [&](const pof::raw_block_t& b, const Delivery&) { blocks.push_back(b.n_scans); });
  RawSender s;
  s.send(u.group, u.port, udpm_short(1, "OTHER_APP", encode(angle(1))));   // nobody's: not verified
  s.send(u.group, u.port, udpm_short(2, "POF_ANGLE", encode(angle(666))));  // unsigned
  pof::bus::Publisher pub(lc, key);
  ASSERT_EQ(pub.publish("POF_ANGLE", angle(7)), 0);
  pof::raw_block_t big{};  // ~120 KB: liblcm sends it in fragments, the trailer in the last one
  big.n_channels = 3;
  big.channel_names = {"sensor", "reference", "pot"};
  big.channel_units = {"V", "V", "V"};
  big.n_scans = 10000;
  big.volts.assign(10000, std::vector<float>(3, 1.5f));
  ASSERT_GT(big.getEncodedSize(), 65536);
  ASSERT_EQ(pub.publish("POF_RAW", big), 0);
  handle_until(rx, [&] { return !angles.empty() && !blocks.empty(); });
  rx.handle(50);
  EXPECT_EQ(angles, (std::vector<std::int64_t>{7}));
  EXPECT_EQ(blocks, (std::vector<std::int32_t>{10000}));
  const auto st = rx.stats();
  EXPECT_EQ(st.auth_unsigned, 1u);
  EXPECT_EQ(st.auth_bad_mac + st.auth_stale + st.auth_replayed, 0u);
  EXPECT_EQ(st.decode_errors, 0u);
}
