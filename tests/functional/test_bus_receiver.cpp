// pof::bus::Receiver over memq:// (liblcm in-process): typed delivery through the bounded decoder,
// raw delivery by liblcm's regex, and totality: decode errors and handler exceptions are counted,
// never thrown. The udpm:// path (our socket, real multicast) is test_bus_receiver_udpm.cpp.
#include <chrono>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "bus_receiver_test.hpp"
#include "lcm_test.hpp"
#include "pof/angle_t.hpp"
#include "pof/bus/receiver.hpp"
#include "pof/base/errors.hpp"
#include "pof/raw_block_t.hpp"

namespace {

using pof::bus::Delivery;
using pof::bus::ReceiveError;
using pof::bus::Receiver;
using pof::test::encode;

using pof::test::handle_until;
pof::angle_t angle(std::int64_t seq) { return pof::test::numbered_angle(seq); }

}  // namespace

TEST(BusReceiver, MemqDecodeAndHandlerErrorsAreCountedNeverThrown) {
  lcm::LCM lc("memq://");
  ASSERT_TRUE(lc.good());
  Receiver rx(lc, "memq://");
  std::vector<std::int64_t> got;
  std::vector<std::string> errors;
  rx.subscribe<pof::angle_t>("POF_ANGLE", [&](const pof::angle_t& a, const Delivery& d) {
    EXPECT_EQ(d.channel, "POF_ANGLE");
    if (a.seq == 2) throw std::runtime_error("handler bug on seq 2");
    got.push_back(a.seq);
  });
  rx.on_error([&](const ReceiveError& e) { errors.push_back(e.describe()); });
  for (std::int64_t i = 0; i < 4; ++i) {
    const pof::angle_t a = angle(i);
    ASSERT_EQ(lc.publish("POF_ANGLE", &a), 0);
  }
  const auto raw = encode(pof::raw_block_t{});  // another type on the channel
  lc.publish("POF_ANGLE", raw.data(), static_cast<unsigned>(raw.size()));
  auto cut = encode(angle(9));
  cut.resize(cut.size() - 3);  // truncated
  lc.publish("POF_ANGLE", cut.data(), static_cast<unsigned>(cut.size()));
  const pof::angle_t last = angle(4);
  ASSERT_EQ(lc.publish("POF_ANGLE", &last), 0);
  handle_until(rx, [&] { return rx.channel_stats("POF_ANGLE").messages >= 7; });

  EXPECT_EQ(got, (std::vector<std::int64_t>{0, 1, 3, 4}));
  const auto st = rx.channel_stats("POF_ANGLE");
  EXPECT_EQ(st.messages, 7u);
  EXPECT_EQ(st.decode_errors, 2u);
  EXPECT_EQ(st.handler_errors, 1u);
  EXPECT_EQ(rx.stats().decode_errors, 2u);
  EXPECT_EQ(rx.stats().handler_errors, 1u);
  ASSERT_EQ(errors.size(), 3u);
  EXPECT_NE(errors[0].find("handler bug on seq 2"), std::string::npos) << errors[0];
  EXPECT_NE(errors[1].find("POF_ANGLE: not a angle_t"), std::string::npos) << errors[1];
  EXPECT_NE(errors[2].find("truncated"), std::string::npos) << errors[2];
}

TEST(BusReceiver, MemqRawUsesLiblcmRegexAndTypedChannelsAreLiteral) {
  lcm::LCM lc("memq://");
  Receiver rx(lc, "memq://");
  std::vector<std::string> raw;
  rx.subscribe_raw("POF_(A|B)", [&](const Delivery& d, const unsigned char*, std::size_t) { raw.emplace_back(d.channel); });
  int dotted = 0;
  rx.subscribe<pof::angle_t>("POF.X", [&](const pof::angle_t&, const Delivery&) { ++dotted; });
  EXPECT_THROW(rx.subscribe_raw("(unclosed", [](const Delivery&, const unsigned char*, std::size_t) {}),
               pof::ConfigError);
  const char x[] = "x";
  for (const char* ch : {"POF_A", "POF_B", "POF_C", "POF_AB"}) lc.publish(ch, x, sizeof x);
  const pof::angle_t a1 = angle(1), a2 = angle(2);
  lc.publish("POFAX", &a1);  // '.' is not a wildcard for a typed channel
  lc.publish("POF.X", &a2);
  lc.publish("POF_END", x, sizeof x);
  handle_until(rx, [&] { return dotted >= 1 && raw.size() >= 2; });
  rx.handle(0);
  EXPECT_EQ(raw, (std::vector<std::string>{"POF_A", "POF_B"}));
  EXPECT_EQ(dotted, 1);
}
