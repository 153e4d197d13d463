// The authenticated mode over memq:// (docs/deployment.md, "Authenticated mode"): a publisher with
// the bus key K (pof::bus::Publisher), a receiver with K (pof::bus::Receiver) takes its stream;
// forged messages (unsigned, signed with another key, altered), a replayed and a stale one are
// dropped before decoding and counted per verdict, and the good stream goes on. Without a key the
// Publisher sends exactly what liblcm's publish() sends.
#include <chrono>
#include <cstdint>
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
#include "pof/lcm/utime.hpp"

namespace {

using pof::bus::Delivery;
using pof::bus::Publisher;
using pof::bus::ReceiveError;
using pof::bus::Receiver;
using pof::bus::ReceiverOptions;
using pof::test::encode;
using pof::test::handle_until;
namespace auth = pof::bus::auth;

std::shared_ptr<const auth::Key> key(unsigned char fill) {
  std::vector<unsigned char> k(auth::Key::kBytes, fill);
  return std::make_shared<const auth::Key>(k.data(), k.size());
}

pof::angle_t angle(std::int64_t seq) { return pof::test::numbered_angle(seq); }

using Bytes = std::vector<unsigned char>;

}  // namespace

TEST(BusAuth, MemqReceiverTakesTheKeyHoldersStreamAndCountsEveryForgery) {
  lcm::LCM lc("memq://");
  ASSERT_TRUE(lc.good());
  const auto k = key(0x11);
  ReceiverOptions ro;
  ro.auth_key = k;
  Receiver rx(lc, "memq://", ro);
  std::vector<std::int64_t> got;
  std::vector<std::size_t> raw_sizes;
  std::vector<std::string> errors;
  rx.subscribe<pof::angle_t>("POF_ANGLE", [&](const pof::angle_t& a, const Delivery&) { got.push_back(a.seq); });
  // A raw subscription on the same channel: liblcm hands each message to both, and it must be
  // verified once (a second verification would take it for its own replay).
  rx.subscribe_raw("POF_.*", [&](const Delivery&, const unsigned char*, std::size_t n) { raw_sizes.push_back(n); });
  rx.on_error([&](const ReceiveError& e) { errors.push_back(e.describe()); });
  // What goes over the bus, as a stock tool (lcm-logger) would log it: a receiver without a key.
  Receiver tap(lc, "memq://");
  std::vector<Bytes> wire;
  tap.subscribe_raw("POF_ANGLE", [&](const Delivery&, const unsigned char* p, std::size_t n) { wire.emplace_back(p, p + n); });

  Publisher good(lc, k);
  ASSERT_TRUE(good.authenticated());
  ASSERT_EQ(good.publish("POF_ANGLE", angle(0)), 0);
  ASSERT_EQ(good.publish("POF_ANGLE", angle(1)), 0);
  handle_until(rx, [&] { return got.size() >= 2; });
  ASSERT_EQ(got, (std::vector<std::int64_t>{0, 1}));
  ASSERT_EQ(wire.size(), 2u);
  const std::size_t plain = encode(angle(0)).size();
  EXPECT_EQ(wire[0].size(), plain + auth::kTrailerBytes);  // the LCM message, then the trailer
  EXPECT_TRUE(std::equal(wire[0].begin(), wire[0].begin() + static_cast<long>(plain), encode(angle(0)).begin()));

  // The forgeries, then the good stream again.
  const pof::angle_t forged = angle(100);
  ASSERT_EQ(lc.publish("POF_ANGLE", &forged), 0);                  // unsigned
  Publisher other_key(lc, key(0x22));
  ASSERT_EQ(other_key.publish("POF_ANGLE", angle(101)), 0);        // signed with another key
  Bytes altered = wire[1];
  altered[20] ^= 0x40;                                             // angle 1 with a changed byte
  lc.publish("POF_ANGLE", altered.data(), static_cast<unsigned>(altered.size()));
  lc.publish("POF_ANGLE", wire[0].data(), static_cast<unsigned>(wire[0].size()));  // angle 0 replayed
  auth::Signer late(k, 77);                                        // the right key, 10 s ago
  Bytes stale = encode(angle(102));
  const std::size_t n = stale.size();
  stale.resize(n + auth::kTrailerBytes);
  ASSERT_TRUE(late.sign("POF_ANGLE", stale.data(), n, auth::counter_time(pof::lcmutil::now_utime() - 10'000'000)));
  lc.publish("POF_ANGLE", stale.data(), static_cast<unsigned>(stale.size()));
  ASSERT_EQ(good.publish("POF_ANGLE", angle(2)), 0);
  ASSERT_EQ(good.publish("POF_ANGLE", angle(3)), 0);
  handle_until(rx, [&] { return got.size() >= 4; });
  rx.handle(0);

  EXPECT_EQ(got, (std::vector<std::int64_t>{0, 1, 2, 3}));
  EXPECT_EQ(raw_sizes, std::vector<std::size_t>(4, plain));  // the trailer taken off for subscribers
  const pof::bus::ReceiverStats st = rx.stats();
  EXPECT_TRUE(st.authenticated);
  EXPECT_EQ(st.auth_unsigned, 1u);
  EXPECT_EQ(st.auth_bad_mac, 2u);
  EXPECT_EQ(st.auth_stale, 1u);
  EXPECT_EQ(st.auth_replayed, 1u);
  EXPECT_EQ(st.decode_errors, 0u);
  EXPECT_EQ(rx.channel_stats("POF_ANGLE").messages, 4u);
  EXPECT_EQ(rx.channel_stats("POF_ANGLE").auth_dropped, 5u);
  ASSERT_EQ(errors.size(), 5u);
  EXPECT_NE(errors[0].find("POF_ANGLE: not authenticated"), std::string::npos) << errors[0];
  EXPECT_NE(errors[1].find("signed with another key"), std::string::npos) << errors[1];
  EXPECT_NE(errors[2].find("forged or altered"), std::string::npos) << errors[2];
  EXPECT_NE(errors[3].find("replayed"), std::string::npos) << errors[3];
  EXPECT_NE(errors[4].find("stale"), std::string::npos) << errors[4];
}

TEST(BusAuth, WithoutAKeyThePublisherSendsWhatLiblcmSends) {
  lcm::LCM lc("memq://");
  Receiver tap(lc, "memq://");
  std::vector<Bytes> wire;
  tap.subscribe_raw("POF_ANGLE", [&](const Delivery&, const unsigned char* p, std::size_t n) { wire.emplace_back(p, p + n); });
  Publisher plain(lc, nullptr);
  EXPECT_FALSE(plain.authenticated());
  const pof::angle_t a = angle(5);
  ASSERT_EQ(plain.publish("POF_ANGLE", a), 0);
  const Bytes encoded = encode(a);
  ASSERT_EQ(plain.publish("POF_ANGLE", encoded.data(), encoded.size()), 0);
  ASSERT_EQ(lc.publish("POF_ANGLE", &a), 0);
  handle_until(tap, [&] { return wire.size() >= 3; });
  ASSERT_EQ(wire.size(), 3u);
  EXPECT_EQ(wire[0], encoded);
  EXPECT_EQ(wire[1], encoded);
  EXPECT_EQ(wire[2], encoded);
}

TEST(BusAuth, AReceiverWithoutTheKeyCountsSignedMessagesAsDecodeErrors) {
  // A mode mismatch shows: pofkit's bounded decoder refuses the trailer's bytes after the message.
  lcm::LCM lc("memq://");
  Receiver rx(lc, "memq://");
  int got = 0;
  rx.subscribe<pof::angle_t>("POF_ANGLE", [&](const pof::angle_t&, const Delivery&) { ++got; });
  std::vector<std::string> errors;
  rx.on_error([&](const ReceiveError& e) { errors.push_back(e.describe()); });
  Publisher signer(lc, key(0x11));
  ASSERT_EQ(signer.publish("POF_ANGLE", angle(1)), 0);
  handle_until(rx, [&] { return rx.channel_stats("POF_ANGLE").messages >= 1; });
  EXPECT_EQ(got, 0);
  EXPECT_EQ(rx.stats().decode_errors, 1u);
  EXPECT_FALSE(rx.stats().authenticated);
  // ... and says why: the log line names the missing key, not only the bytes it could not read.
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("signed (authenticated mode) and this process has no bus key"), std::string::npos) << errors[0];
  EXPECT_NE(errors[0].find("--auth-key-file"), std::string::npos) << errors[0];

  // An unsigned message that does not decode is not blamed on a key.
  const unsigned char junk[] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  lc.publish("POF_ANGLE", junk, sizeof junk);
  handle_until(rx, [&] { return rx.channel_stats("POF_ANGLE").messages >= 2; });
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[1].find("bus key"), std::string::npos) << errors[1];
}
