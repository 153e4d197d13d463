// The streaming path in-process (no USB, no LCM): scans in through the ScanSink interface the
// backends use, blocks out of the SPSC queue the publisher reads. Decimation, block assembly,
// continuous indices, gap handling after a lost session, overruns, timestamps.
#include <gtest/gtest.h>

#include <vector>

#include "pof/daq/stream/acquisition.hpp"
#include "pof/daq/stream/config.hpp"
#include "pof/raw_block_t.hpp"

using pof::daq::Acquisition;
using pof::daq::Block;
using pof::daq::Counters;
using pof::daq::DaqConfig;
using pof::daq::SpscQueue;

namespace {

constexpr std::int64_t kT0 = 1'700'000'000'000'000;

struct Rig {
  explicit Rig(int decimate, int block_scans, std::size_t queue_blocks = 64)
      : queue(queue_blocks) {
    cfg.decimate = decimate;
    cfg.block_scans = block_scans;
    acq = std::make_unique<Acquisition>(cfg, 1000.0, queue, counters, wake);
  }
  // n scans of channel values (i, 10 + i, 20 + i) for device index i, from index `from`.
  void feed(std::int64_t from, std::size_t n, std::int64_t arrival_us) {
    std::vector<float> v(n * 3);
    for (std::size_t k = 0; k < n; ++k) {
      const auto i = static_cast<float>(from + static_cast<std::int64_t>(k));
      v[3 * k] = i;
      v[3 * k + 1] = 10 + i;
      v[3 * k + 2] = 20 + i;
    }
    acq->on_scans(v.data(), n, arrival_us, 0);
  }
  std::vector<Block> drain() {
    std::vector<Block> out;
    while (Block* b = queue.front()) {
      out.push_back(*b);
      queue.pop();
    }
    return out;
  }
  DaqConfig cfg;
  SpscQueue<Block> queue;
  Counters counters;
  pof::daq::Doorbell wake;
  std::unique_ptr<Acquisition> acq;
};

}  // namespace

TEST(Acquisition, DecimatesIntoBlocksWithContinuousIndices) {
  Rig r(4, 3);
  r.acq->on_segment_start(kT0, kT0, false);
  for (int chunk = 0; chunk < 10; ++chunk) r.feed(chunk * 12, 12, kT0 + (chunk + 1) * 12'000 + 500);
  const auto blocks = r.drain();
  ASSERT_EQ(blocks.size(), 10U);  // 120 scans / 4 = 30 published scans / 3 per block
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    EXPECT_EQ(blocks[b].first_scan, static_cast<std::int64_t>(3 * b));
    EXPECT_EQ(blocks[b].n_scans, 3);
    EXPECT_EQ(blocks[b].flags, 0);
    // The first published scan of block b averages device scans 12b..12b+3: mean 12b + 1.5,
    // and stands for the middle of its window: t0 + (12b + 1.5) ms.
    EXPECT_FLOAT_EQ(blocks[b].volts[0], static_cast<float>(12 * b) + 1.5F);
    EXPECT_FLOAT_EQ(blocks[b].volts[1], static_cast<float>(12 * b) + 11.5F);
    EXPECT_FLOAT_EQ(blocks[b].volts[5], static_cast<float>(12 * b + 4) + 21.5F);
    EXPECT_EQ(blocks[b].utime, kT0 + static_cast<std::int64_t>(12 * b) * 1000 + 1500);
  }
  EXPECT_EQ(r.counters.scans.load(), 120);
  EXPECT_EQ(r.counters.dropped_scans.load(), 0);
}

TEST(Acquisition, ContinuousSegmentKeepsTheIndexAndReanchorsTime) {
  Rig r(1, 10);
  r.acq->on_segment_start(kT0, kT0, false);
  r.feed(0, 100, kT0 + 100'000 + 300);
  // The next finite segment starts 20 ms after the last scan's period ended (a seam).
  const std::int64_t t1 = kT0 + 120'000;
  r.acq->on_segment_start(t1, t1, true);
  r.feed(100, 100, t1 + 100'000 + 300);
  const auto blocks = r.drain();
  ASSERT_EQ(blocks.size(), 20U);
  EXPECT_EQ(blocks[10].first_scan, 100);
  EXPECT_EQ(blocks[10].flags, 0);  // no gap: the index carried over
  EXPECT_EQ(blocks[10].utime, t1);
  EXPECT_EQ(r.counters.dropped_scans.load(), 0);
}

TEST(Acquisition, LostSessionAdvancesTheIndexByTheOutageAndFlagsIt) {
  Rig r(2, 5);
  r.acq->on_segment_start(kT0, kT0, false);
  r.feed(0, 101, kT0 + 101'000 + 300);  // 50 published scans + half a window
  // Replug 1 s after scan 101 would have started: 1000 device scans lost, plus the half window
  // (scan 100): published scans 50..550 are missing.
  const std::int64_t t1 = kT0 + 1'101'000;
  r.acq->on_segment_start(t1, t1, false);
  r.feed(0, 20, t1 + 20'000 + 300);
  const auto blocks = r.drain();
  ASSERT_EQ(blocks.size(), 12U);
  const Block& after = blocks[10];
  EXPECT_NE(after.flags & int32_t{pof::raw_block_t::FLAG_GAP}, 0);
  EXPECT_EQ(after.first_scan, 551);
  EXPECT_EQ(r.counters.dropped_scans.load(), after.first_scan - 50);  // counter == index hole
  EXPECT_FLOAT_EQ(after.volts[0], 0.5F);  // the partial window from before the gap was dropped
  EXPECT_EQ(blocks[11].flags, 0);
}

TEST(Acquisition, FullQueueCountsOverrunsAndFlagsTheHole) {
  Rig r(1, 1, 4);
  r.acq->on_segment_start(kT0, kT0, false);
  r.feed(0, 10, kT0 + 10'000 + 300);  // 10 blocks into a 4-deep queue
  EXPECT_EQ(r.counters.overruns.load(), 6);
  EXPECT_EQ(r.counters.dropped_scans.load(), 6);
  auto blocks = r.drain();
  ASSERT_EQ(blocks.size(), 4U);
  r.feed(10, 1, kT0 + 11'000 + 300);
  blocks = r.drain();
  ASSERT_EQ(blocks.size(), 1U);
  EXPECT_EQ(blocks[0].first_scan, 10);
  EXPECT_NE(blocks[0].flags & int32_t{pof::raw_block_t::FLAG_GAP}, 0);
}
