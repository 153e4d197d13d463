// pof-daqd's publisher (daq/daemon/daemon.hpp) over real liblcm: every message LCM refuses is counted and
// carried by the status. liblcm 1.3.1's udpm:// refuses a channel name longer than
// LCM_MAX_CHANNEL_NAME_LENGTH, the refusal a test can provoke: a 56-character sensor id makes both
// POF_RAW_<id> and POF_DAQ_STATUS_<id> too long, so every raw block and status is refused. (The
// statuses then cannot be received: the status the daemon would publish is read from it instead.)
#include <chrono>
#include <random>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "daemon.hpp"
#include "poll.hpp"
#include "pof/bus/url.hpp"
#include "pof/daq/stream/backend.hpp"

namespace {

pof::daq::DaqConfig sim_config(const std::string& sensor_id) {
  std::mt19937 rng(std::random_device{}());
  pof::daq::DaqConfig cfg;
  cfg.device_kind = "sim:synthetic";
  cfg.sensor_id = sensor_id;
  cfg.lcm_url = pof::bus::resolve_url("udpm://239.255.76.67:" + std::to_string(20000 + rng() % 30000) + "?ttl=0");
  cfg.status_period_s = 0.05;
  return cfg;
}

// Waits (10 s at most) until `done()`, polling the daemon's counters.
template <class Done>
bool wait_until(Done done) {
  return pof::test::poll_until(done, std::chrono::seconds(10), std::chrono::milliseconds(5));
}

}  // namespace

TEST(DaqdPublish, EveryRefusedMessageIsCountedAndInTheStatus) {
  const pof::daq::DaqConfig cfg = sim_config(std::string(56, 'X'));
  ASSERT_GT(cfg.raw_channel().size(), std::size_t{LCM_MAX_CHANNEL_NAME_LENGTH});
  pof::daq::Daemon d(cfg, pof::daq::make_backend(cfg));
  d.start();
  ASSERT_TRUE(wait_until([&] { return d.publish_failures() >= 20; })) << d.publish_failures();
  d.stop();
  const pof::daq_status_t st = d.status(pof::daq::State::kStopping, "stopped");
  // Every raw block (counted in blocks as it left the queue) and every status was refused: at
  // least the first status (starting) and the final one (stopping) besides the blocks.
  EXPECT_GE(st.publish_failures, st.blocks + 2);
  EXPECT_GT(st.blocks, 0);
  EXPECT_EQ(st.publish_failures, d.publish_failures());
}

struct Received {
  int statuses = 0;
  std::int64_t publish_failures = -1;
};

TEST(DaqdPublish, NothingIsCountedWhenLcmPublishes) {
  const pof::daq::DaqConfig cfg = sim_config("LEFT_KNEE");
  lcm::LCM rx(cfg.lcm_url);
  ASSERT_TRUE(rx.good());
  Received got;
  rx.subscribeFunction(
      cfg.status_channel(),
      +[](const lcm::ReceiveBuffer*, const std::string&, const pof::daq_status_t* s, Received* r) {
        ++r->statuses;
        r->publish_failures = s->publish_failures;
      },
      &got);
  pof::daq::Daemon d(cfg, pof::daq::make_backend(cfg));
  d.start();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (got.statuses < 3 && std::chrono::steady_clock::now() < deadline) rx.handleTimeout(100);
  d.stop();
  ASSERT_GE(got.statuses, 3);
  EXPECT_EQ(got.publish_failures, 0);  // the field as received
  EXPECT_EQ(d.publish_failures(), 0);
}
