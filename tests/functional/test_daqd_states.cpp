// pof-daqd's state machine (daq/daemon/daemon.hpp) in-process: the daemon runs on a scripted backend
// (fake_backend.hpp) and publishes on a memq:// bus the test reads through pof::bus::Receiver.
// Everything is checked from what the daemon publishes: the POF_DAQ_STATUS state sequence and its
// reasons and counters, and the POF_RAW blocks (seq, first_scan, FLAG_GAP, the volts themselves).
// The test waits on those messages or on the backend's condition variable, never on time alone.
#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "daemon.hpp"
#include "fake_backend.hpp"
#include "pof/bus/receiver.hpp"
#include "pof/daq_status_t.hpp"
#include "pof/raw_block_t.hpp"

namespace {

using pof::daq_status_t;
using pof::raw_block_t;
using pof::test::FakeBackend;
using Attempt = FakeBackend::Attempt;
using std::chrono::milliseconds;

constexpr double kRateHz = 1000.0;
constexpr int kDecimate = 2;
constexpr int kBlockScans = 5;  // published scans per block: one block per 10 device scans
// Generous for a loaded 2-core CI host; the daemon's own bound is one 20-ms retry-wait slice or
// one turn of the backend's event loop (1 ms for the fake).
constexpr auto kStopBound = milliseconds(2000);
constexpr auto kWait = milliseconds(10000);

using Transition = std::pair<int, std::string>;  // daq_status_t.state, state_text

class Rig {
 public:
  // A session the test holds open without scans is reported stalled after `stall_ms`
  // (daemon.stall_ms): a minute, except in the test about stalls, so that a slow host never turns
  // another test's hold into a stall.
  explicit Rig(int retry_ms = 10, int stall_ms = 60000) {
    cfg_.device_kind = "fake";
    cfg_.sensor_id = "FAKE";
    cfg_.scan_rate_hz = kRateHz;
    cfg_.decimate = kDecimate;
    cfg_.block_scans = kBlockScans;
    cfg_.retry_ms = retry_ms;
    cfg_.stall_ms = stall_ms;
    cfg_.lcm_url = "memq://";
    auto fake = std::make_unique<FakeBackend>(cfg_.channels().size(), kRateHz);
    fake_ = fake.get();
    rx_ = std::make_unique<pof::bus::Receiver>(lc_, "memq://");
    rx_->subscribe<daq_status_t>(cfg_.status_channel(),
                                 [this](const daq_status_t& s, const pof::bus::Delivery&) { status_.push_back(s); });
    rx_->subscribe<raw_block_t>(cfg_.raw_channel(),
                                [this](const raw_block_t& b, const pof::bus::Delivery&) { raw_.push_back(b); });
    daemon_ = std::make_unique<pof::daq::Daemon>(cfg_, std::move(fake), lc_);
  }

  FakeBackend& fake() { return *fake_; }
  pof::daq::Daemon& daemon() { return *daemon_; }
  const std::vector<daq_status_t>& status() const { return status_; }
  const std::vector<raw_block_t>& raw() const { return raw_; }

  /// Handles the bus until `done()` (true) or kWait (false).
  template <class Done>
  bool until(Done done) {
    const auto deadline = std::chrono::steady_clock::now() + kWait;
    while (!done()) {
      if (std::chrono::steady_clock::now() >= deadline) return false;
      rx_->handle(20);
    }
    return true;
  }

  /// The published states with consecutive repeats (the 1-Hz status) folded. The publisher
  /// thread starts first and may publish its initial "starting" before the acquisition thread's
  /// first state: that one is left out, so that both orders give the same sequence.
  [[nodiscard]] std::vector<Transition> transitions() const {
    std::vector<Transition> out;
    for (const auto& s : status_) {
      Transition t{s.state, s.state_text};
      if (out.empty() && t == Transition{daq_status_t::STATE_STARTING, "starting"}) continue;
      if (out.empty() || out.back() != t) out.push_back(std::move(t));
    }
    return out;
  }
  [[nodiscard]] int count(int state) const {
    int n = 0;
    for (const auto& t : transitions()) n += t.first == state ? 1 : 0;
    return n;
  }

  /// Stops the daemon, returns how long stop() took, then takes every message it published.
  milliseconds stop() {
    const auto t0 = std::chrono::steady_clock::now();
    daemon_->stop();
    const auto took = std::chrono::duration_cast<milliseconds>(std::chrono::steady_clock::now() - t0);
    while (rx_->handle(0) > 0) {
    }
    return took;
  }

 private:
  pof::daq::DaqConfig cfg_;
  lcm::LCM lc_{"memq://"};
  std::unique_ptr<pof::bus::Receiver> rx_;
  FakeBackend* fake_ = nullptr;
  std::vector<daq_status_t> status_;
  std::vector<raw_block_t> raw_;
  std::unique_ptr<pof::daq::Daemon> daemon_;  // last: stopped before what its threads use
};

constexpr int kStarting = daq_status_t::STATE_STARTING;
constexpr int kStreaming = daq_status_t::STATE_STREAMING;
constexpr int kDisconnected = daq_status_t::STATE_DISCONNECTED;
constexpr int kFault = daq_status_t::STATE_FAULT;
constexpr int kStopping = daq_status_t::STATE_STOPPING;

const Transition kOpening{kStarting, "opening fake"};
const Transition kConfigured{kStarting, "configured fake, waiting for scans"};
const Transition kStreamingT{kStreaming, "streaming from fake"};
const Transition kStoppedOnRequest{kStopping, "stopped on request"};

// Status messages are numbered without a hole from 0; so are raw blocks, across sessions.
void expect_seq_continuous(const Rig& r) {
  for (std::size_t i = 0; i < r.status().size(); ++i) EXPECT_EQ(r.status()[i].seq, std::int64_t(i)) << "status " << i;
  for (std::size_t i = 0; i < r.raw().size(); ++i) EXPECT_EQ(r.raw()[i].seq, std::int64_t(i)) << "block " << i;
}

// first_scan follows the previous block's last scan, except at the blocks listed in `gaps`, which
// carry FLAG_GAP (and only they) and whose first_scan moves on by at least a block.
void expect_scan_indices(const Rig& r, const std::vector<std::size_t>& gaps) {
  const auto& raw = r.raw();
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const bool gap = std::find(gaps.begin(), gaps.end(), i) != gaps.end();
    EXPECT_EQ((raw[i].flags & raw_block_t::FLAG_GAP) != 0, gap) << "block " << i << " flags " << raw[i].flags;
    EXPECT_EQ(raw[i].flags & ~raw_block_t::FLAG_GAP, 0) << "block " << i;
    EXPECT_EQ(raw[i].n_scans, kBlockScans) << "block " << i;
    if (i == 0) continue;
    const std::int64_t follows = raw[i - 1].first_scan + raw[i - 1].n_scans;
    if (gap) {
      EXPECT_GE(raw[i].first_scan, follows) << "block " << i;
    } else {
      EXPECT_EQ(raw[i].first_scan, follows) << "block " << i;
    }
  }
}

}  // namespace

TEST(DaqdStates, OpensConfiguresStreamsAndStopsOnRequest) {
  Rig r;
  r.fake().push(Attempt::opens().scans(100).hold());
  r.daemon().start();
  ASSERT_TRUE(r.until([&] { return r.count(kStreaming) == 1 && r.raw().size() == 10; }))
      << "streaming states " << r.count(kStreaming) << ", blocks " << r.raw().size();
  EXPECT_LT(r.stop(), kStopBound);

  EXPECT_EQ(r.transitions(), (std::vector<Transition>{kOpening, kConfigured, kStreamingT, kStoppedOnRequest}));
  expect_seq_continuous(r);
  expect_scan_indices(r, {});
  // The data path: published scan j averages device scans 2j and 2j+1 (values 1000 c + index).
  ASSERT_EQ(r.raw().size(), 10U);
  for (const auto& b : r.raw()) {
    ASSERT_EQ(b.n_channels, 3);
    EXPECT_EQ(b.channel_names, (std::vector<std::string>{"sensor", "reference", "pot"}));
    EXPECT_DOUBLE_EQ(b.scan_rate_hz, kRateHz / kDecimate);
    for (int k = 0; k < b.n_scans; ++k) {
      for (std::size_t c = 0; c < 3; ++c) {
        EXPECT_FLOAT_EQ(b.volts[std::size_t(k)][c], float(1000 * c) + float(kDecimate * (b.first_scan + k)) + 0.5F)
            << "block " << b.seq << " scan " << k << " channel " << c;
      }
    }
  }
  const daq_status_t& last = r.status().back();
  EXPECT_EQ(last.scans, 100);
  EXPECT_EQ(last.blocks, 10);
  EXPECT_EQ(last.usb_errors, 0);
  EXPECT_EQ(last.reconnects, 0);
  EXPECT_EQ(last.dropped_scans, 0);
  EXPECT_EQ(last.serial, "FAKE0001");
  EXPECT_EQ(last.vendor_id, 0x1234);
  EXPECT_EQ(r.fake().opens(), 1);
  EXPECT_GE(r.fake().closes(), 1);
}

TEST(DaqdStates, ReconnectsAfterADisconnectAndFlagsTheFirstBlockAfterIt) {
  Rig r;
  r.fake().push(Attempt::opens().scans(100).hold().disconnect("fake: device gone (LIBUSB_ERROR_NO_DEVICE)"));
  r.fake().push(Attempt::absent("fake: not attached"));
  r.fake().push(Attempt::opens().scans(60).hold());
  r.daemon().start();
  ASSERT_TRUE(r.until([&] { return r.count(kStreaming) == 1; }));
  r.fake().release();  // unplug
  ASSERT_TRUE(r.until([&] { return r.count(kStreaming) == 2 && r.raw().size() == 16; }))
      << "streaming states " << r.count(kStreaming) << ", blocks " << r.raw().size();
  EXPECT_LT(r.stop(), kStopBound);

  EXPECT_EQ(r.transitions(),
            (std::vector<Transition>{kOpening, kConfigured, kStreamingT,
                                     {kDisconnected, "fake: device gone (LIBUSB_ERROR_NO_DEVICE)"},
                                     kOpening, {kDisconnected, "fake: not attached"},
                                     kOpening, kConfigured, kStreamingT, kStoppedOnRequest}));
  expect_seq_continuous(r);
  expect_scan_indices(r, {10});  // the first block of the second session
  EXPECT_EQ(r.status().back().reconnects, 1);
  EXPECT_EQ(r.status().back().scans, 160);
  EXPECT_EQ(r.fake().opens(), 3);
}

TEST(DaqdStates, OpenFailuresAreRetriedAndTheStatusSaysWhy) {
  Rig r;
  r.fake().push(Attempt::fault("fake: claiming interface 0: LIBUSB_ERROR_BUSY"));
  r.fake().push(Attempt::throws("libusb_open: out of memory"));  // breaks the never-throws contract
  r.fake().push(Attempt::opens().stream_throws("transfer callback: bad_alloc"));
  r.fake().push(Attempt::opens().scans(20).hold());
  r.daemon().start();
  ASSERT_TRUE(r.until([&] { return r.count(kStreaming) == 1; }));
  EXPECT_LT(r.stop(), kStopBound);

  EXPECT_EQ(r.transitions(),
            (std::vector<Transition>{kOpening, {kFault, "fake: claiming interface 0: LIBUSB_ERROR_BUSY"},
                                     kOpening, {kFault, "fake: opening failed: libusb_open: out of memory"},
                                     kOpening, kConfigured, {kFault, "fake: streaming failed: transfer callback: bad_alloc"},
                                     kOpening, kConfigured, kStreamingT, kStoppedOnRequest}));
  expect_seq_continuous(r);
  EXPECT_EQ(r.fake().opens(), 4);
  // Failed opens are no reconnect; the open after the session that failed while streaming is.
  EXPECT_EQ(r.status().back().reconnects, 1);
  EXPECT_EQ(r.status().back().scans, 20);
}

TEST(DaqdStates, ReadErrorsAreCountedAndAnErrorEndIsRecoveredWithAGap) {
  Rig r;
  r.fake().push(Attempt::opens().scans(50).usb_error().usb_error().scans(50).hold().usb_error().error(
      "fake: endpoint 0x82: LIBUSB_ERROR_IO"));
  r.fake().push(Attempt::opens().scans(50).hold());
  r.daemon().start();
  ASSERT_TRUE(r.until([&] { return r.count(kStreaming) == 1 && r.raw().size() == 10; }));
  r.fake().release();
  ASSERT_TRUE(r.until([&] { return r.count(kStreaming) == 2 && r.raw().size() == 15; }))
      << "streaming states " << r.count(kStreaming) << ", blocks " << r.raw().size();
  EXPECT_LT(r.stop(), kStopBound);

  EXPECT_EQ(r.transitions(),
            (std::vector<Transition>{kOpening, kConfigured, kStreamingT, {kFault, "fake: endpoint 0x82: LIBUSB_ERROR_IO"},
                                     kOpening, kConfigured, kStreamingT, kStoppedOnRequest}));
  // Every status from the fault on carries the three errors; none before the first was read.
  bool faulted = false;
  for (const auto& s : r.status()) {
    faulted = faulted || s.state == kFault;
    if (faulted) {
      EXPECT_EQ(s.usb_errors, 3) << "status " << s.seq << " " << s.state_text;
    }
    EXPECT_LE(s.usb_errors, 3);
  }
  EXPECT_TRUE(faulted);
  expect_seq_continuous(r);
  expect_scan_indices(r, {10});
  EXPECT_EQ(r.status().back().reconnects, 1);
}

TEST(DaqdStates, StopsPromptlyWhenTheDeviceStalls) {
  Rig r;
  r.fake().push(Attempt::opens().scans(20));  // then silent
  r.daemon().start();
  ASSERT_TRUE(r.fake().wait_stalled(kWait));
  ASSERT_TRUE(r.until([&] { return r.count(kStreaming) == 1 && r.raw().size() == 2; }));
  EXPECT_LT(r.stop(), kStopBound);
  EXPECT_EQ(r.transitions(), (std::vector<Transition>{kOpening, kConfigured, kStreamingT, kStoppedOnRequest}));
  expect_seq_continuous(r);
}

TEST(DaqdStates, StopsPromptlyWhileBackingOffAfterAFault) {
  Rig r(/*retry_ms=*/60000);  // a back-off the stop request must cut short
  r.fake().push(Attempt::fault("fake: LIBUSB_ERROR_BUSY"));
  r.daemon().start();
  ASSERT_TRUE(r.until([&] { return r.count(kFault) == 1; }));
  EXPECT_LT(r.stop(), kStopBound);
  EXPECT_EQ(r.transitions(),
            (std::vector<Transition>{kOpening, {kFault, "fake: LIBUSB_ERROR_BUSY"}, kStoppedOnRequest}));
  EXPECT_EQ(r.fake().opens(), 1);
  expect_seq_continuous(r);
}

TEST(DaqdStates, AFiniteSourceEndsTheDaemonWithItsReason) {
  Rig r;
  r.fake().push(Attempt::opens().scans(40).finish("fake: scenario over"));
  r.daemon().start();
  ASSERT_TRUE(r.until([&] { return r.daemon().finished() && r.count(kStopping) == 1; }));
  EXPECT_LT(r.stop(), kStopBound);
  // The scans of a session that ends at once may or may not be seen as streaming first.
  auto t = r.transitions();
  std::erase(t, kStreamingT);
  EXPECT_EQ(t, (std::vector<Transition>{kOpening, kConfigured, {kStopping, "fake: scenario over"}}));
  EXPECT_EQ(r.status().back().scans, 40);
  EXPECT_EQ(r.raw().size(), 4U);
  expect_seq_continuous(r);
  expect_scan_indices(r, {});
}

// A session that stops delivering scans while it stays open (a device read that blocks, a frozen
// acquisition thread) is not reported as streaming once the stall bound has passed: `fault` with
// the reason, `streaming` again when scans come. The scans it hands over after the stall keep
// their indices (no gap) but are old: every such block carries FLAG_LATE, and none before it.
TEST(DaqdStates, AStallLeavesStreamingAndTheBacklogAfterItIsFlaggedLate) {
  constexpr int kStallMs = 200;
  Rig r(/*retry_ms=*/10, kStallMs);
  r.fake().push(Attempt::opens().scans(10).hold().scans(100).hold());
  r.daemon().start();
  ASSERT_TRUE(r.until([&] { return r.count(kStreaming) == 1 && r.raw().size() == 1; }));
  ASSERT_TRUE(r.until([&] { return r.count(kFault) == 1; })) << "no stall reported";
  // Hold on past the stall: the backlog's newest scan (index 109, 109 ms after the first) must be
  // more than the stall bound old when it is handed over.
  const auto hold_until = std::chrono::steady_clock::now() + milliseconds(3 * kStallMs);
  ASSERT_TRUE(r.until([&] { return std::chrono::steady_clock::now() >= hold_until; }));
  r.fake().release();
  ASSERT_TRUE(r.until([&] { return r.count(kStreaming) == 2 && r.raw().size() == 11; }))
      << "streaming states " << r.count(kStreaming) << ", blocks " << r.raw().size();
  EXPECT_LT(r.stop(), kStopBound);

  const auto t = r.transitions();
  ASSERT_GE(t.size(), 6U);
  EXPECT_EQ(t[0], kOpening);
  EXPECT_EQ(t[1], kConfigured);
  EXPECT_EQ(t[2], kStreamingT);
  EXPECT_EQ(t[3].first, kFault);
  EXPECT_EQ(t[3].second.rfind("acquisition stalled: no scans from fake for ", 0), 0U) << t[3].second;
  EXPECT_NE(t[3].second.find("(stall bound 200 ms)"), std::string::npos) << t[3].second;
  EXPECT_EQ(t[4], kStreamingT);
  EXPECT_EQ(t.back(), kStoppedOnRequest);  // the second hold may be reported stalled before it
  // Reported within the bound plus the publisher's turn, with slack for a loaded host.
  for (const auto& s : r.status()) {
    if (s.state != kFault) continue;
    const std::int64_t after_last_block_us = s.utime - r.raw()[0].publish_utime;
    EXPECT_GE(after_last_block_us, (kStallMs - 60) * 1000) << s.state_text;
    EXPECT_LT(after_last_block_us, (kStallMs + 2000) * 1000) << s.state_text;
    break;
  }
  ASSERT_EQ(r.raw().size(), 11U);
  EXPECT_EQ(r.raw()[0].flags, 0) << "a block published in time is not late";
  for (std::size_t i = 1; i < r.raw().size(); ++i) {
    const auto& b = r.raw()[i];
    EXPECT_EQ(b.flags, raw_block_t::FLAG_LATE) << "block " << i << " flags " << b.flags;
    EXPECT_EQ(b.first_scan, r.raw()[i - 1].first_scan + r.raw()[i - 1].n_scans) << "block " << i;
    EXPECT_GT(b.publish_utime - b.utime, kStallMs * 1000) << "block " << i;
  }
  expect_seq_continuous(r);
  EXPECT_EQ(r.status().back().dropped_scans, 0);
  EXPECT_EQ(r.status().back().scans, 110);
}
