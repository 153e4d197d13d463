// pof::bus::parse_udpm_datagram (common/bus/include/pof/bus/udpm_receiver.hpp): the header checks of our
// udpm:// receive path, on hand-made datagrams. What UdpmReceiver does with the parts (reassembly,
// bounds, counters) is tested over real multicast (tests/functional/test_bus_receiver_udpm.cpp);
// tests/fuzz/fuzz_udpm_datagram.cpp feeds it arbitrary bytes.
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "pof/bus/udpm_receiver.hpp"
#include "udpm_wire.hpp"

namespace {

using pof::bus::parse_udpm_datagram;
using pof::bus::UdpmDatagram;
using Kind = UdpmDatagram::Kind;
using pof::test::udpm_fragment;
using pof::test::udpm_short;

constexpr std::uint32_t kLimit = 16u << 20;

UdpmDatagram parse(const std::vector<unsigned char>& d, std::uint32_t limit = kLimit) {
  return parse_udpm_datagram(d.data(), d.size(), limit);
}

std::vector<unsigned char> bytes(std::size_t n, unsigned char v = 0xAB) { return std::vector<unsigned char>(n, v); }

}  // namespace

TEST(UdpmDatagram, ShortMessageIsChannelAndPayload) {
  const std::vector<unsigned char> payload{1, 0, 2, 3};  // a '\0' in the payload is payload
  const auto d = udpm_short(77, "POF_ANGLE", payload);
  const UdpmDatagram p = parse(d);
  ASSERT_EQ(p.kind, Kind::kShort);
  EXPECT_EQ(p.seq, 77u);
  EXPECT_EQ(p.channel, "POF_ANGLE");
  EXPECT_EQ(std::vector<unsigned char>(p.payload, p.payload + p.payload_size), payload);
  EXPECT_EQ(p.payload + p.payload_size, d.data() + d.size());
  EXPECT_EQ(parse(udpm_short(1, "X", {})).payload_size, 0u);  // an empty message is a message
}

TEST(UdpmDatagram, FragmentZeroCarriesTheChannelTheOthersDoNot) {
  const auto d0 = udpm_fragment(5, 300, 0, 0, 3, "POF_RAW", bytes(100));  // channel and payload point into it
  const UdpmDatagram f0 = parse(d0);
  ASSERT_EQ(f0.kind, Kind::kFragment);
  EXPECT_EQ(f0.seq, 5u);
  EXPECT_EQ(f0.channel, "POF_RAW");
  EXPECT_EQ(f0.message_size, 300u);
  EXPECT_EQ(f0.offset, 0u);
  EXPECT_EQ(f0.fragment, 0u);
  EXPECT_EQ(f0.fragments, 3u);
  EXPECT_EQ(f0.payload_size, 100u);
  const auto d2 = udpm_fragment(5, 300, 200, 2, 3, "", bytes(100, 0));  // its body may start with '\0'
  const UdpmDatagram f2 = parse(d2);
  ASSERT_EQ(f2.kind, Kind::kFragment);
  EXPECT_TRUE(f2.channel.empty());
  EXPECT_EQ(f2.payload, d2.data() + 20);
  EXPECT_EQ(f2.payload_size, 100u);  // and ends exactly at the message's end
}

TEST(UdpmDatagram, ImpossibleHeadersAreMalformed) {
  const std::string longest(63, 'C');  // lcm.h: LCM_MAX_CHANNEL_NAME_LENGTH
  EXPECT_EQ(parse(udpm_short(1, longest, {})).kind, Kind::kShort);
  const std::vector<std::vector<unsigned char>> bad{
      {},
      bytes(7),
      bytes(64),                                    // no magic
      udpm_short(1, "", bytes(4)),                  // no channel
      udpm_short(1, longest + "C", {}),             // channel too long
      {0x4C, 0x43, 0x30, 0x32, 0, 0, 0, 1, 'N', 'O'},  // LC02 without '\0'
      {0x4C, 0x43, 0x30, 0x33, 0, 0, 0, 1, 0, 0},   // LC03 shorter than its header
      udpm_fragment(1, 0, 0, 0, 1, "C", {}),        // message of 0 bytes
      udpm_fragment(1, kLimit + 1, 0, 1, 300, "", bytes(10)),  // above the limit
      udpm_fragment(1, 100, 0, 0, 0, "C", bytes(10)),          // no fragments
      udpm_fragment(1, 100, 0, 2, 2, "", bytes(10)),           // number beyond the count
      udpm_fragment(1, 100, 0, 0, 2, "", bytes(10, 1)),        // fragment 0 without '\0'
      udpm_fragment(1, 100, 0xFFFFFFFFu, 1, 2, "", bytes(1)),  // liblcm 1.3.1's crash
      udpm_fragment(1, 100, 91, 1, 2, "", bytes(10)),          // one byte beyond the message
      udpm_fragment(1, 100, 0, 0, 2, "C", bytes(101)),
  };
  for (std::size_t i = 0; i < bad.size(); ++i) EXPECT_EQ(parse(bad[i]).kind, Kind::kMalformed) << "case " << i;
  EXPECT_EQ(parse(udpm_fragment(1, 100, 90, 1, 2, "", bytes(10))).kind, Kind::kFragment);
  EXPECT_EQ(parse(udpm_fragment(1, 1000, 0, 1, 2, "", bytes(10)), 999).kind, Kind::kMalformed);  // the caller's limit
}
