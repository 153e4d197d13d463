// The daemon's pure parts: the scan clock (drift, causality), the SPSC hand-off and the
// configuration errors (each names its key), the publisher's doorbell.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <random>
#include <thread>

#include "pof/base/toml_reader.hpp"
#include "pof/daq/stream/config.hpp"
#include "pof/daq/stream/doorbell.hpp"
#include "pof/daq/stream/liveness.hpp"
#include "pof/daq/stream/scan_clock.hpp"
#include "pof/daq/stream/spsc_queue.hpp"
#include "pof/base/errors.hpp"

using pof::daq::ScanClock;

namespace {

// A device clock `ppm` fast, scans of `rate` Hz, transfers of `per` scans, arriving after a
// random latency >= min_lat_us. Returns the worst |t(i) - truth(i)| after `settle_s`.
double worst_error_us(double ppm, double rate, int per, double min_lat_us, double run_s, double settle_s,
                      std::int64_t anchor_late_us) {
  ScanClock clock(rate);
  const std::int64_t t0 = 1'700'000'000'000'000;
  clock.anchor(0, t0 - 100, t0 + anchor_late_us);
  std::mt19937 rng(42);
  std::exponential_distribution<double> jitter(1.0 / 300.0);
  const double period = 1e6 / (rate * (1.0 + ppm * 1e-6));
  double worst = 0;
  for (std::int64_t last = per - 1; static_cast<double>(last) * period < run_s * 1e6; last += per) {
    const double truth_last = static_cast<double>(t0) + static_cast<double>(last) * period;
    const auto arrival = static_cast<std::int64_t>(truth_last + period + min_lat_us + jitter(rng));
    clock.observe(last, arrival);
    if (static_cast<double>(last) * period > settle_s * 1e6) {
      worst = std::max(worst, std::abs(static_cast<double>(clock.time_of(static_cast<double>(last))) - truth_last));
    }
  }
  return worst;
}

}  // namespace

TEST(ScanClock, NoDriftNoLatencyIsExact) {
  ScanClock c(1000.0);
  c.anchor(0, 1000, 1000);
  EXPECT_EQ(c.time_of(0), 1000);
  EXPECT_EQ(c.time_of(1000), 1'001'000);
  EXPECT_EQ(c.time_of(0.5), 1500);
}

TEST(ScanClock, FollowsA300PpmFastDeviceWithinAMillisecond) {
  // Uncorrected, 300 ppm is 3 ms after 10 s and 18 ms after 60 s.
  const double worst = worst_error_us(300.0, 2000.0, 10, 50.0, 60.0, 10.0, 0);
  EXPECT_LT(worst, 1000.0) << "worst " << worst << " us";
}

TEST(ScanClock, FollowsASlowDeviceToo) {
  EXPECT_LT(worst_error_us(-200.0, 16000.0, 64, 50.0, 60.0, 10.0, 0), 1000.0);
}

TEST(ScanClock, CausalityPullsALateAnchorBackButNotBeforeTheStartCommand) {
  // Anchored 5 ms late: the first transfers arrive "before" their scans and pull it back.
  EXPECT_LT(worst_error_us(0.0, 2000.0, 10, 20.0, 5.0, 0.5, 5000), 400.0);
  ScanClock c(1000.0);
  c.anchor(0, 10'000, 20'000);
  c.observe(0, 10'500);  // would need the anchor at 9'500: the floor (10'000) holds
  EXPECT_EQ(c.time_of(0), 10'000);
}

TEST(SpscQueue, FullQueueRefusesInsteadOfBlocking) {
  pof::daq::SpscQueue<int> q(2);
  EXPECT_EQ(q.capacity(), 2U);
  for (int v : {1, 2}) {
    int* slot = q.producer_slot();
    ASSERT_NE(slot, nullptr);
    *slot = v;
    q.commit();
  }
  EXPECT_EQ(q.producer_slot(), nullptr);
  const int* f = q.front();
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(*f, 1);
  q.pop();
  ASSERT_NE(q.producer_slot(), nullptr);
  f = q.front();
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(*f, 2);
  q.pop();
  EXPECT_EQ(q.front(), nullptr);
}

TEST(SpscQueue, TwoThreadsKeepOrderAndLoseNothingAccepted) {
  pof::daq::SpscQueue<long> q(64);
  constexpr long kN = 200000;
  long refused = 0;
  std::thread producer([&] {
    for (long i = 0; i < kN; ++i) {
      long* s = q.producer_slot();
      while (s == nullptr) {
        ++refused;
        std::this_thread::yield();
        s = q.producer_slot();
      }
      *s = i;
      q.commit();
    }
  });
  long expect = 0;
  while (expect < kN) {
    if (long* v = q.front()) {
      ASSERT_EQ(*v, expect);
      ++expect;
      q.pop();
    }
  }
  producer.join();
  EXPECT_EQ(expect, kN);
}

namespace {
std::string config_error(const std::string& toml) {
  try {
    (void)pof::daq::config_from_table(toml::parse(toml), "t.toml");
  } catch (const pof::ConfigError& e) {
    EXPECT_EQ(e.code(), pof::kExitConfig);
    return e.what();
  }
  return "";
}
}  // namespace

TEST(DaqConfig, DefaultsAndOverrides) {
  toml::table t = toml::parse("schema_version = 1\n[acquisition]\nscan_rate_hz = 1000.0\n");
  pof::apply_toml_override(t, "acquisition.decimate=5");
  pof::apply_toml_override(t, "device.kind=sim:synthetic");  // a bare word is a string
  pof::apply_toml_override(t, "lcm.sensor_id=\"LEFT_KNEE\"");
  const auto c = pof::daq::config_from_table(t, "t.toml");
  EXPECT_DOUBLE_EQ(c.scan_rate_hz, 1000.0);
  EXPECT_EQ(c.decimate, 5);
  EXPECT_EQ(c.device_kind, "sim:synthetic");
  EXPECT_EQ(c.raw_channel(), "POF_RAW_LEFT_KNEE");
  EXPECT_EQ(c.status_channel(), "POF_DAQ_STATUS_LEFT_KNEE");
  EXPECT_DOUBLE_EQ(c.published_rate_hz(), 200.0);
  ASSERT_EQ(c.channels().size(), 3U);
  EXPECT_EQ(c.channels()[1].name, "reference");
  EXPECT_THROW(pof::apply_toml_override(t, "novalue"), pof::ConfigError);
}

TEST(DaqConfig, Usb1208lsAutoModeScansWithASoftwarePacedFallback) {
  // mcc_usb1208ls.hpp [9]: "auto" scans, and reads single AIns if the device refuses the
  // scan's feature report; its rate limits are those of scan mode.
  const auto c = pof::daq::config_from_table(
      toml::parse("schema_version = 1\n[device]\nkind = 'usb1208ls'\n[acquisition]\nmcc_mode = 'auto'\n"), "t.toml");
  EXPECT_TRUE(c.mcc_fallback_single);
  EXPECT_FALSE(c.mcc_single_reads);
  EXPECT_NE(pof::daq::to_toml(c).find("mcc_mode = 'auto'"), std::string::npos);
  EXPECT_NE(config_error("schema_version = 1\n[device]\nkind = 'usb1208ls'\n[acquisition]\nmcc_mode = 'auto'\n"
                         "scan_rate_hz = 10.0").find("acquisition.scan_rate_hz"), std::string::npos);
}

TEST(DaqConfig, EveryErrorNamesItsKey) {
  EXPECT_NE(config_error("").find("schema_version"), std::string::npos);
  EXPECT_NE(config_error("schema_version = 1\n[acquisition]\nscan_rate_hz = 'fast'").find("acquisition.scan_rate_hz"), std::string::npos);
  EXPECT_NE(config_error("schema_version = 1\n[acquisition]\nscan_rate_hz = 4000.0").find("10000 S/s aggregate"), std::string::npos);
  EXPECT_NE(config_error("schema_version = 1\n[device]\nkind = 'usb6009'\n[acquisition]\nscan_rate_hz = 17000.0").find("acquisition.scan_rate_hz"), std::string::npos);
  EXPECT_EQ(config_error("schema_version = 1\n[device]\nkind = 'usb6009'\n[acquisition]\nscan_rate_hz = 16000.0"), "");
  EXPECT_NE(config_error("schema_version = 1\n[acquisition]\nterminal = 'differential'\n[channels]\nsensor = 5").find("channels.sensor"), std::string::npos);
  EXPECT_NE(config_error("schema_version = 1\n[channels]\npot = 0").find("channels.pot"), std::string::npos);
  EXPECT_NE(config_error("schema_version = 1\n[lcm]\nsensor_id = 'left knee'").find("lcm.sensor_id"), std::string::npos);
  EXPECT_NE(config_error("schema_version = 1\n[lcm]\nurl = 3").find("lcm.url"), std::string::npos);
  EXPECT_NE(config_error("schema_version = 1\n[daemon]\nretry = 3").find("t.toml:3: unknown key 'retry' in [daemon] (did you mean 'retry_ms'?)"), std::string::npos);
  EXPECT_NE(config_error("schema_version = 1\n[acquisition]\nsegment_scans = 1001").find("acquisition.segment_scans"), std::string::npos);
  EXPECT_NE(config_error("schema_version = 1\ndevice = 3").find("'device'"), std::string::npos);
}

// Lines, unknown keys with a suggestion, and the command line's values (no line: the source says
// "command line"), as every pofkit TOML file reports them (common/base/include/pof/base/toml_reader.hpp).
TEST(DaqConfig, ErrorsNameTheLineAndSuggestTheKnownKey) {
  EXPECT_EQ(config_error("schema_version = 1\n[acquisition]\nscan_rate_hz = 'fast'"),
            "t.toml:3: key 'acquisition.scan_rate_hz': expected a number, got a string 'fast'");
  EXPECT_EQ(config_error("schema_version = 1\n[channels]\npot = 0"),
            "t.toml:3: key 'channels.pot': expected an input not used by channels.sensor, got 0");
  EXPECT_EQ(config_error("schema_version = 1\n\n[acquisition]\ndecimate_by = 3"),
            "t.toml:4: unknown key 'decimate_by' in [acquisition] (did you mean 'decimate'?)");
  EXPECT_EQ(config_error("schema_version = 1\n[lcm]\nurl = 'memq://'\n[aquisition]\ndecimate = 3"),
            "t.toml:4: unknown key 'aquisition' at the top level (did you mean 'acquisition'?)");
  toml::table t = toml::parse("schema_version = 1\n[acquisition]\ndecimate = 10\n");
  pof::apply_toml_override(t, "acquisition.decimate=0");
  std::string e;
  try {
    (void)pof::daq::config_from_table(t, "t.toml + command line");
  } catch (const pof::ConfigError& x) {
    e = x.what();
  }
  EXPECT_EQ(e, "t.toml + command line: key 'acquisition.decimate': expected an integer in [1, 10000], got 0");
  pof::apply_toml_override(t, "acquisition.decimate=5");
  pof::apply_toml_override(t, "acquisition.decimat=5");
  try {
    (void)pof::daq::config_from_table(t, "t.toml + command line");
  } catch (const pof::ConfigError& x) {
    e = x.what();
  }
  EXPECT_EQ(e, "t.toml + command line: unknown key 'decimat' in [acquisition] (did you mean 'decimate'?)");
}

// --- Doorbell (daq/include/pof/daq/stream/doorbell.hpp): the acquisition -> publisher wake-up -------------------------

TEST(Doorbell, RingBeforeWaitIsNotLostAndRingsCoalesce) {
  pof::daq::Doorbell bell;
  EXPECT_FALSE(bell.try_wait());
  bell.ring();
  bell.ring();
  bell.ring();
  EXPECT_TRUE(bell.try_wait());   // three rings, one wake-up: the publisher drains the queue anyway
  EXPECT_FALSE(bell.try_wait());
}

TEST(Doorbell, TimesOutWithoutARing) {
  pof::daq::Doorbell bell;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(20);
  EXPECT_FALSE(bell.wait_until(deadline));
  EXPECT_GE(std::chrono::steady_clock::now(), deadline);
}

TEST(Doorbell, ARingFromAnotherThreadWakesASleepingWaiter) {
  // The waiter sleeps in FUTEX_WAIT with a 60-s deadline; only the ring can end the wait before
  // it, and a lost wake-up shows as `false` (after 60 s), not as a flaky timing bound.
  pof::daq::Doorbell bell;
  for (int round = 0; round < 20; ++round) {
    std::thread ringer([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(round % 2 == 0 ? 5 : 0));
      bell.ring();
    });
    EXPECT_TRUE(bell.wait_until(std::chrono::steady_clock::now() + std::chrono::seconds(60))) << "round " << round;
    ringer.join();
  }
}

// The stall bound (docs/daq.md, "Watchdog and stalls"): 10 block periods, or 10 x 32 device scans
// when a hand-over is longer, never under 500 ms; daemon.stall_ms overrides it.
TEST(Liveness, StallBoundFollowsTheBlockPeriodWithAFloor) {
  pof::daq::DaqConfig c;  // 2000 scans/s, decimate 10, 1 scan per block: 5-ms blocks
  EXPECT_EQ(pof::daq::stall_bound_ms(c, c.scan_rate_hz), 500);
  c.block_scans = 50;  // 250-ms blocks
  EXPECT_EQ(pof::daq::stall_bound_ms(c, c.scan_rate_hz), 2500);
  c.block_scans = 1;
  c.decimate = 1;
  c.scan_rate_hz = 40;  // 32 scans take 800 ms: a hand-over, not a block, sets the bound
  EXPECT_EQ(pof::daq::stall_bound_ms(c, c.scan_rate_hz), 8000);
  c.stall_ms = 1234;
  EXPECT_EQ(pof::daq::stall_bound_ms(c, c.scan_rate_hz), 1234);
  // The watchdog waits the stall bound plus the longest wait a backend makes on purpose.
  c.data_timeout_ms = 2000;
  c.command_timeout_ms = 1000;
  EXPECT_EQ(pof::daq::watchdog_grace_ms(c, 500), 2500);
  const auto t = config_error("schema_version = 1\n[daemon]\nstall_ms = -1");
  EXPECT_NE(t.find("daemon.stall_ms"), std::string::npos) << t;
  toml::table tt = toml::parse("schema_version = 1\n[daemon]\nstall_ms = 750\n");
  EXPECT_EQ(pof::daq::config_from_table(tt, "t.toml").stall_ms, 750);
}

// Scans or the state machine's heartbeat keep the acquisition alive for the watchdog; only scans
// keep a stream from being stalled. A frozen thread is neither, whatever the publisher does.
TEST(Liveness, ScansKeepItStreamingAndEitherKindOfProgressFeedsTheWatchdog) {
  using std::chrono::milliseconds;
  const auto t0 = pof::daq::Liveness::Clock::now();
  pof::daq::Liveness live(milliseconds(500), milliseconds(1500), t0);
  live.observe(t0, 100, 0);
  EXPECT_FALSE(live.scans_stalled(t0 + milliseconds(500)));
  EXPECT_TRUE(live.scans_stalled(t0 + milliseconds(501)));
  EXPECT_TRUE(live.alive(t0 + milliseconds(1500)));
  EXPECT_FALSE(live.alive(t0 + milliseconds(1501)));
  // The same counts sampled again are no progress: the publisher turning proves nothing.
  for (int ms = 0; ms <= 2000; ms += 50) live.observe(t0 + milliseconds(ms), 100, 0);
  EXPECT_FALSE(live.alive(t0 + milliseconds(2000)));
  EXPECT_EQ(live.since_scans(t0 + milliseconds(2000)), milliseconds(2000));
  // The heartbeat (reconnecting, backing off) feeds the watchdog but is not scans.
  live.observe(t0 + milliseconds(2100), 100, 1);
  EXPECT_TRUE(live.alive(t0 + milliseconds(2100)));
  EXPECT_TRUE(live.scans_stalled(t0 + milliseconds(2100)));
  live.observe(t0 + milliseconds(2200), 101, 1);
  EXPECT_FALSE(live.scans_stalled(t0 + milliseconds(2600)));
  EXPECT_EQ(live.scans(), 101);
}

TEST(Liveness, ABlockPublishedLongAfterItsLastScanIsLate) {
  EXPECT_FALSE(pof::daq::block_is_late(1'000'000, 1'004'000, 500));   // one transfer behind
  EXPECT_FALSE(pof::daq::block_is_late(1'000'000, 1'500'000, 500));
  EXPECT_TRUE(pof::daq::block_is_late(1'000'000, 1'500'001, 500));
  EXPECT_TRUE(pof::daq::block_is_late(1'000'000, 4'000'000, 500));    // the backlog of a 3-s stall
}
