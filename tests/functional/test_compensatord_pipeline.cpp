// pof-compensatord's pipeline (compensator/daemon/pipeline.hpp): raw blocks in, angles and cycle
// statistics out. Fed by the simulator's `validation` scenario; checked against the offline path
// (`pof compensate`), for gaps, bad blocks, decimation, reloads and over a real memq:// bus.
#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "lcm_sink.hpp"
#include "pipeline.hpp"
#include "pof/base/errors.hpp"
#include "pof/bus/channels.hpp"
#include "pof/bus/error_log.hpp"
#include "pof/bus/publisher.hpp"
#include "pof/core/model.hpp"
#include "pof/core/offline.hpp"
#include "pof/bus/receiver.hpp"
#include "pof/sim/scenario.hpp"
#include "pof/sim/simulator.hpp"

namespace {

using pof::compensatord::Pipeline;
using pof::compensatord::PipelineSettings;

struct Collect final : pof::compensatord::Sink {
  std::vector<pof::angle_t> angles;
  std::vector<pof::cycle_stats_t> cycles;
  bool angle(const pof::angle_t& m) override {
    angles.push_back(m);
    return true;
  }
  bool cycle(const pof::cycle_stats_t& m) override {
    cycles.push_back(m);
    return true;
  }
};

constexpr int kScansPerBlock = 20;
constexpr std::int64_t kEpochUtime = 1'700'000'000'000'000;

std::vector<pof::sim::Scan> simulate(double seconds) {
  pof::sim::Scenario sc = pof::sim::builtin_scenario("validation");
  sc.duration_s = seconds;
  pof::sim::Simulator sim(sc, 7, 0);
  std::vector<pof::sim::Scan> out, buf(1000);
  while (const std::size_t n = sim.next(buf)) out.insert(out.end(), buf.begin(), buf.begin() + long(n));
  return out;
}

std::vector<pof::raw_block_t> blocks_of(const std::vector<pof::sim::Scan>& scans) {
  std::vector<pof::raw_block_t> blocks;
  for (std::size_t i = 0; i + kScansPerBlock <= scans.size(); i += kScansPerBlock) {
    pof::raw_block_t b{};
    b.utime = kEpochUtime + std::llround(scans[i].t_s * 1e6);
    b.seq = std::int64_t(blocks.size());
    b.first_scan = std::int64_t(i);
    b.scan_rate_hz = 200.0;
    b.n_channels = 4;
    b.channel_names = {"sensor", "reference", "pot", "angle_ref"};
    b.channel_units = {"V", "V", "V", "deg"};
    b.n_scans = kScansPerBlock;
    for (int k = 0; k < kScansPerBlock; ++k) {
      const auto& s = scans[i + size_t(k)];
      b.volts.push_back({float(s.sensor_v), float(s.reference_v), float(s.pot_v), float(s.angle_ref_deg)});
    }
    blocks.push_back(std::move(b));
  }
  return blocks;
}

pof::io::CalibrationFile paper_calibration() {
  pof::io::CalibrationFile f;
  f.sensor_id = "SIM_PAPER";
  f.date = "2026-11-21T00:00:00Z";
  f.cal.model = pof::core::paper_coefficients();
  f.cal.reference_level_v = 4.0;  // validation.toml's light.reference_level_v
  return f;
}

class PipelineTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scans_ = new std::vector<pof::sim::Scan>(simulate(230));
    blocks_ = new std::vector<pof::raw_block_t>(blocks_of(*scans_));
  }
  static void TearDownTestSuite() {
    delete scans_;
    delete blocks_;
  }
  static std::vector<pof::sim::Scan>* scans_;

  struct OfflineInputs {
    Eigen::VectorXd t, s, r, a;
  };
  // The recording the blocks carry, for the offline path: the pipeline sees the float samples of
  // the message, so the offline path gets the same.
  static OfflineInputs offline_inputs() {
    const auto n = Eigen::Index(blocks_->size() * kScansPerBlock);
    OfflineInputs in{Eigen::VectorXd(n), Eigen::VectorXd(n), Eigen::VectorXd(n), Eigen::VectorXd(n)};
    for (Eigen::Index i = 0; i < n; ++i) {
      const auto& sc = (*scans_)[size_t(i)];
      in.t[i] = double(i) / 200.0;
      in.s[i] = double(float(sc.sensor_v));
      in.r[i] = double(float(sc.reference_v));
      in.a[i] = double(float(sc.angle_ref_deg));
    }
    return in;
  }
  static std::vector<pof::raw_block_t>* blocks_;
};
std::vector<pof::sim::Scan>* PipelineTest::scans_ = nullptr;
std::vector<pof::raw_block_t>* PipelineTest::blocks_ = nullptr;

// The daemon and `pof compensate` must agree bit for bit (in the float the message carries).
TEST_F(PipelineTest, EveryScanMatchesTheOfflinePath) {
  Pipeline p(paper_calibration(), "paper.toml", PipelineSettings{});
  Collect out;
  for (const auto& b : *blocks_) p.on_block(b, 0, out);

  const auto n = Eigen::Index(blocks_->size() * kScansPerBlock);
  const auto [t, s, r, a] = offline_inputs();
  const pof::core::OfflineResult off = pof::core::compensate_recording(t, s, r, a, paper_calibration().cal);

  ASSERT_EQ(Eigen::Index(out.angles.size()), n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& m = out.angles[size_t(i)];
    ASSERT_EQ(m.seq, i);
    ASSERT_EQ(m.scan_index, i);
    if (std::isnan(off.angle_deg[i])) {
      ASSERT_TRUE(std::isnan(m.angle_deg)) << "scan " << i;
    } else {
      ASSERT_EQ(m.angle_deg, float(off.angle_deg[i])) << "scan " << i;
    }
    ASSERT_EQ(m.quality, off.quality[size_t(i)]) << "scan " << i;
  }
  // Cycles close at the next flexion or after a hold; finish() (the stream went quiet, or the
  // daemon stops) closes the last one as the offline path does at the end of the recording: the
  // daemon publishes every cycle `pof compensate` reports, the last one included.
  const std::size_t before_finish = out.cycles.size();
  p.finish(out);
  ASSERT_GE(out.cycles.size(), 3u);
  EXPECT_EQ(out.cycles.size(), off.cycles.size()) << before_finish << " before finish()";
  p.finish(out);  // nothing left to close
  EXPECT_EQ(out.cycles.size(), off.cycles.size());
  for (size_t c = 0; c < std::min(out.cycles.size(), off.cycles.size()); ++c) {
    EXPECT_EQ(out.cycles[c].cycle, off.cycles[c].cycle);
    EXPECT_EQ(out.cycles[c].rmse_comp_deg, float(off.cycles[c].rmse_comp_deg));
    EXPECT_EQ(out.cycles[c].seq, std::int64_t(c));
    EXPECT_LT(out.cycles[c].rmse_comp_deg, out.cycles[c].rmse_uncomp_deg) << "compensation must help";
    // utime is the cycle's last scan (cycle_stats_t.lcm), not the scan that closed it.
    EXPECT_EQ(out.cycles[c].utime, out.cycles[c].end_utime);
    EXPECT_NEAR(double(out.cycles[c].end_utime - kEpochUtime), off.cycles[c].t_end_s * 1e6, 2.0);
  }
  const auto st = p.status(0);
  EXPECT_EQ(st.scans, n);
  EXPECT_EQ(st.lost_scans, 0);
  EXPECT_EQ(st.lost_blocks, 0);
  EXPECT_EQ(st.angles, n);
  EXPECT_EQ(st.cycles, std::int64_t(out.cycles.size()));
}

TEST_F(PipelineTest, ReplayIsDeterministic) {
  Collect a, b;
  Pipeline p1(paper_calibration(), "x", PipelineSettings{}), p2(paper_calibration(), "x", PipelineSettings{});
  for (const auto& blk : *blocks_) p1.on_block(blk, 1, a);
  for (const auto& blk : *blocks_) p2.on_block(blk, 2, b);
  ASSERT_EQ(a.angles.size(), b.angles.size());
  for (size_t i = 0; i < a.angles.size(); ++i) {
    ASSERT_EQ(std::memcmp(&a.angles[i].angle_deg, &b.angles[i].angle_deg, sizeof(float)), 0);
    ASSERT_EQ(a.angles[i].utime, b.angles[i].utime);
  }
}

TEST_F(PipelineTest, APotChannelWithoutItsCalibrationIsNamedInTheStatus) {
  // The reference comes from the pot volts only (no angle_ref channel), as from a real DAQ.
  std::vector<pof::raw_block_t> blocks((*blocks_).begin(), (*blocks_).begin() + 100);
  for (auto& b : blocks) {
    b.n_channels = 3;
    b.channel_names.resize(3);
    b.channel_units.resize(3);
    for (auto& v : b.volts) v.resize(3);
  }
  Pipeline bare(paper_calibration(), "x", PipelineSettings{});
  Collect out;
  for (const auto& b : blocks) bare.on_block(b, 0, out);
  EXPECT_EQ(bare.status(0).last_error, pof::compensatord::kNoPotentiometer);
  EXPECT_TRUE(std::isnan(out.angles.back().angle_ref_deg));

  pof::core::PotentiometerCalibration pot;
  pot.deg_per_volt = 22.5;
  pot.zero_v = 0.5;
  Pipeline with_pot(paper_calibration(), "x", PipelineSettings{}, pot);
  Collect out2;
  for (const auto& b : blocks) with_pot.on_block(b, 0, out2);
  EXPECT_EQ(with_pot.status(0).last_error, "");
  EXPECT_FALSE(std::isnan(out2.angles.back().angle_ref_deg));
}

TEST_F(PipelineTest, ALateBlockIsCompensatedAndEveryAngleOfItFlaggedLate) {
  Pipeline p(paper_calibration(), "x", PipelineSettings{});
  Pipeline reference(paper_calibration(), "x", PipelineSettings{});
  Collect out, ref_out;
  for (size_t i = 0; i < 120; ++i) {
    pof::raw_block_t b = (*blocks_)[i];
    reference.on_block(b, 0, ref_out);
    if (i >= 100 && i < 110) b.flags |= pof::raw_block_t::FLAG_LATE;  // a stall's backlog
    p.on_block(b, 0, out);
  }
  ASSERT_EQ(out.angles.size(), ref_out.angles.size());
  for (size_t k = 0; k < out.angles.size(); ++k) {
    const bool late = k >= 100 * kScansPerBlock && k < 110 * kScansPerBlock;
    EXPECT_EQ((out.angles[k].quality & pof::angle_t::QUALITY_LATE) != 0, late) << k;
    // Nothing else changes: the angle and the model's memory are those of an on-time stream.
    EXPECT_EQ(out.angles[k].angle_deg, ref_out.angles[k].angle_deg) << k;
    EXPECT_EQ(out.angles[k].quality & ~pof::angle_t::QUALITY_LATE, ref_out.angles[k].quality) << k;
  }
}

TEST_F(PipelineTest, LostBlockIsCountedAndResetsTheEstimator) {
  Pipeline p(paper_calibration(), "x", PipelineSettings{});
  Collect out;
  for (size_t i = 0; i < 200; ++i)
    if (i != 100) p.on_block((*blocks_)[i], 0, out);
  const auto st = p.status(0);
  EXPECT_EQ(st.lost_blocks, 1);
  EXPECT_EQ(st.lost_scans, kScansPerBlock);
  const auto& first_after = out.angles[100 * kScansPerBlock];
  EXPECT_EQ(first_after.scan_index, 101 * kScansPerBlock);
  EXPECT_TRUE(first_after.quality & pof::angle_t::QUALITY_GAP);
  EXPECT_TRUE(first_after.quality & pof::angle_t::QUALITY_SETTLING);
  EXPECT_FALSE(out.angles[100 * kScansPerBlock - 1].quality & pof::angle_t::QUALITY_GAP);
}

TEST_F(PipelineTest, PublisherRestartIsANewStreamNotALoss) {
  Pipeline p(paper_calibration(), "x", PipelineSettings{});
  Collect out;
  for (size_t i = 0; i < 50; ++i) p.on_block((*blocks_)[i], 0, out);
  pof::raw_block_t again = (*blocks_)[50];
  again.seq = 0;  // pof-daqd restarted; the device scan index carries on
  p.on_block(again, 0, out);
  EXPECT_EQ(p.status(0).lost_blocks, 0);
  EXPECT_EQ(p.status(0).lost_scans, 0);
}

TEST_F(PipelineTest, UnusableBlocksAreRejectedNotFatal) {
  Pipeline p(paper_calibration(), "x", PipelineSettings{});
  Collect out;
  pof::raw_block_t no_sensor = (*blocks_)[0];
  no_sensor.channel_names[0] = "something_else";
  p.on_block(no_sensor, 0, out);
  pof::raw_block_t ragged = (*blocks_)[1];
  ragged.volts[3].pop_back();
  p.on_block(ragged, 0, out);
  pof::raw_block_t bad_rate = (*blocks_)[2];
  bad_rate.scan_rate_hz = std::nan("");
  p.on_block(bad_rate, 0, out);
  EXPECT_EQ(p.status(0).rejected_blocks, 3);
  EXPECT_TRUE(out.angles.empty());
  p.on_block((*blocks_)[3], 0, out);  // and the next good block is processed
  EXPECT_EQ(out.angles.size(), size_t(kScansPerBlock));
}

TEST_F(PipelineTest, FaultsAreFlaggedNeverHidden) {
  Pipeline p(paper_calibration(), "x", PipelineSettings{});
  Collect out;
  pof::raw_block_t b = (*blocks_)[0];
  b.volts[5][1] = 0.0f;           // reference lost (laser off, fibre unplugged)
  b.volts[6][0] = std::nanf("");  // invalid sample
  b.volts[7][0] = 10.0f;          // at the +-10 V range limit
  p.on_block(b, 0, out);
  EXPECT_TRUE(out.angles[5].quality & pof::angle_t::QUALITY_REFERENCE_LOST);
  EXPECT_TRUE(out.angles[6].quality & pof::angle_t::QUALITY_INVALID_INPUT);
  EXPECT_TRUE(std::isnan(out.angles[6].angle_deg));
  EXPECT_TRUE(out.angles[7].quality & pof::angle_t::QUALITY_OVER_RANGE);
  EXPECT_EQ(p.status(0).fault_scans, 3);
}

TEST_F(PipelineTest, DoubtfulBlocksAreNeverPublishedAsGoodAndTheNextGoodOneSettlesAgain) {
  Pipeline p(paper_calibration(), "x", PipelineSettings{});
  Collect out;
  for (size_t i = 0; i < 10; ++i) p.on_block((*blocks_)[i], 0, out);
  pof::raw_block_t doubtful = (*blocks_)[10];
  doubtful.flags |= pof::raw_block_t::FLAG_DOUBTFUL;  // e.g. the byte order not yet told
  p.on_block(doubtful, 0, out);
  p.on_block((*blocks_)[11], 0, out);
  ASSERT_EQ(out.angles.size(), size_t(12 * kScansPerBlock));
  for (int k = 0; k < kScansPerBlock; ++k) {
    const auto& a = out.angles[size_t(10 * kScansPerBlock + k)];
    EXPECT_TRUE(std::isnan(a.angle_deg)) << k;
    EXPECT_TRUE(a.quality & pof::angle_t::QUALITY_INVALID_INPUT) << k;
  }
  EXPECT_EQ(p.status(0).fault_scans, kScansPerBlock);
  const auto& next = out.angles[size_t(11 * kScansPerBlock)];
  EXPECT_TRUE(next.quality & pof::angle_t::QUALITY_SETTLING);
  EXPECT_FALSE(next.quality & pof::angle_t::QUALITY_GAP);  // nothing was lost
  EXPECT_TRUE(std::isfinite(next.angle_deg));
}

TEST_F(PipelineTest, DecimationPublishesTheMeanOfEachWindow) {
  Collect every, dec;
  Pipeline p1(paper_calibration(), "x", PipelineSettings{});
  PipelineSettings s;
  s.output_rate_hz = 50;  // 200 Hz / 4
  Pipeline p2(paper_calibration(), "x", s);
  for (size_t i = 0; i < 100; ++i) {
    p1.on_block((*blocks_)[i], 0, every);
    p2.on_block((*blocks_)[i], 0, dec);
  }
  ASSERT_EQ(dec.angles.size(), every.angles.size() / 4);
  for (size_t j = 0; j < dec.angles.size(); ++j) {
    double mean = 0;
    for (size_t k = 0; k < 4; ++k) mean += double(every.angles[4 * j + k].angle_deg);
    EXPECT_NEAR(double(dec.angles[j].angle_deg), mean / 4, 1e-4);
    // utime is the window's centre: between its 2nd and 3rd scans.
    EXPECT_EQ(dec.angles[j].utime, (every.angles[4 * j].utime + every.angles[4 * j + 3].utime) / 2);
  }
}

TEST_F(PipelineTest, ReloadSwapsTheCalibrationAndCountsFailures) {
  Pipeline p(paper_calibration(), "a.toml", PipelineSettings{});
  Collect before, after;
  Pipeline old_cal(paper_calibration(), "a.toml", PipelineSettings{});  // what block 1 gives on a.toml
  old_cal.on_block((*blocks_)[0], 0, before);
  before.angles.clear();
  old_cal.on_block((*blocks_)[1], 0, before);
  Collect ignored;
  p.on_block((*blocks_)[0], 0, ignored);
  pof::io::CalibrationFile shifted = paper_calibration();
  shifted.cal.model.c10 += 5.0;  // a calibration 5 deg off
  shifted.sensor_id = "OTHER";
  p.replace_calibration(shifted, "b.toml");
  p.on_block((*blocks_)[1], 0, after);
  ASSERT_FALSE(after.angles.empty());
  EXPECT_NEAR(double(after.angles[0].angle_uncomp_deg - before.angles[0].angle_uncomp_deg), 5.0, 1e-3);
  p.note_reload_failure("b.toml: key 'quasi_static.c9': expected a finite number");
  const auto st = p.status(0);
  EXPECT_EQ(st.reloads, 1);
  EXPECT_EQ(st.reload_failures, 1);
  EXPECT_EQ(st.calibration_path, "b.toml");
  EXPECT_EQ(st.calibration_sensor_id, "OTHER");
  EXPECT_NE(st.last_error.find("quasi_static.c9"), std::string::npos);
}

// Swapped knees: a calibration made for another sensor is refused at start and on reload (the
// old one stays, the failure is counted and named), unless the daemon is told to take it; a file
// or a daemon without a sensor id names no sensor and is taken.
TEST_F(PipelineTest, AnotherSensorsCalibrationIsRefused) {
  PipelineSettings left;
  left.sensor_id = "LEFT_KNEE";
  pof::io::CalibrationFile right = paper_calibration();
  right.sensor_id = "RIGHT_KNEE";
  try {
    Pipeline p(right, "right.toml", left);
    FAIL() << "RIGHT_KNEE's calibration was taken by LEFT_KNEE's compensator";
  } catch (const pof::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("right.toml: sensor_id 'RIGHT_KNEE'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'LEFT_KNEE'"), std::string::npos) << e.what();
  }
  pof::io::CalibrationFile own = paper_calibration();
  own.sensor_id = "LEFT_KNEE";
  Pipeline p(own, "left.toml", left);
  Collect out;
  p.on_block((*blocks_)[0], 0, out);
  try {
    p.replace_calibration(right, "right.toml");
    FAIL() << "a reload took RIGHT_KNEE's calibration";
  } catch (const pof::ConfigError& e) {
    p.note_reload_failure(e.what());
  }
  const auto st = p.status(0);
  EXPECT_EQ(st.reloads, 0);
  EXPECT_EQ(st.reload_failures, 1);
  EXPECT_EQ(st.calibration_path, "left.toml");
  EXPECT_EQ(st.calibration_sensor_id, "LEFT_KNEE");
  EXPECT_NE(st.last_error.find("RIGHT_KNEE"), std::string::npos);
  // Told to take it; and ids that name no sensor.
  PipelineSettings any = left;
  any.allow_other_sensor = true;
  EXPECT_NO_THROW(Pipeline(right, "right.toml", any));
  pof::io::CalibrationFile anonymous = paper_calibration();
  anonymous.sensor_id.clear();
  EXPECT_NO_THROW(Pipeline(anonymous, "anon.toml", left));
  EXPECT_NO_THROW(Pipeline(right, "right.toml", PipelineSettings{}));
}

pof::io::CalibrationFile gap_calibration(double notch_hz) {
  pof::io::CalibrationFile f = paper_calibration();
  pof::core::GapModel g;
  g.delay_s = 0.01;
  g.backlash_deg = 0.5;
  pof::core::GapTerm creep;
  creep.effect = "creep";
  creep.theta = 5.0;
  creep.coefficients_v = {-0.001};
  pof::core::GapTerm mains;
  mains.effect = "periodic_interference";
  mains.theta = notch_hz;
  mains.coefficients_v = {0.001, 0.0, 0.0, 0.0};
  g.terms = {creep, mains};
  f.cal.gap = g;
  return f;
}

// The daemon applies a calibration's [gap] terms exactly as `pof compensate` does; a reload with
// a term it cannot apply at the running rate is refused, naming the file, and the old one stays;
// blocks at a rate the terms cannot run at are dropped and counted.
TEST_F(PipelineTest, GapTermsAreAppliedAsOfflineAndAReloadThatCannotApplyThemKeepsTheOld) {
  Pipeline p(gap_calibration(50), "gap.toml", PipelineSettings{});
  Collect out;
  const std::size_t half = blocks_->size() / 2;
  for (std::size_t i = 0; i < half; ++i) p.on_block((*blocks_)[i], 0, out);
  try {
    p.replace_calibration(gap_calibration(150), "bad.toml");
    ADD_FAILURE() << "a notch above Nyquist was accepted";
  } catch (const pof::ConfigError& e) {
    EXPECT_EQ(std::string(e.what()),
              "bad.toml: compensator: [gap] term 2 'periodic_interference': the frequency 150 Hz is at or above the Nyquist "
              "frequency 100 Hz of 200 Hz scans: no notch can remove it");
    p.note_reload_failure(e.what());
  }
  for (std::size_t i = half; i < blocks_->size(); ++i) p.on_block((*blocks_)[i], 0, out);
  EXPECT_EQ(p.status(0).calibration_path, "gap.toml");
  EXPECT_EQ(p.status(0).reload_failures, 1);

  const auto n = Eigen::Index(blocks_->size() * kScansPerBlock);
  const auto [t, s, r, a] = offline_inputs();
  const auto with = pof::core::compensate_recording(t, s, r, a, gap_calibration(50).cal);
  const auto without = pof::core::compensate_recording(t, s, r, a, paper_calibration().cal);
  ASSERT_EQ(Eigen::Index(out.angles.size()), n);
  double moved = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    // One float step apart at most: the notch and the delay's fit are built from the scan rate,
    // which the daemon takes from the block (200 Hz) and compensate_recording from the median
    // spacing of its timestamps (200.0000000002 Hz for i / 200.0): the double angles differ by
    // ~1e-11 deg, which now and then falls on either side of a float rounding boundary.
    const float f = float(with.angle_deg[i]);
    ASSERT_LE(std::abs(out.angles[size_t(i)].angle_deg - f), std::nextafter(std::abs(f), INFINITY) - std::abs(f))
        << "scan " << i;
    moved = std::max(moved, std::abs(with.angle_deg[i] - without.angle_deg[i]));
  }
  EXPECT_GT(moved, 0.1) << "the terms changed nothing";

  // At 80 Hz the 50 Hz notch cannot run: those blocks are dropped and counted, never compensated.
  Pipeline slow(gap_calibration(50), "gap.toml", PipelineSettings{});
  Collect none;
  auto b = (*blocks_)[0];
  b.scan_rate_hz = 80;
  slow.on_block(b, 0, none);
  EXPECT_TRUE(none.angles.empty());
  EXPECT_EQ(slow.status(0).rejected_blocks, 1);
}

// Duplicated and replayed blocks (the same or an older first_scan, seq not advancing) are dropped
// and counted; the angles are exactly those of the clean stream, published once.
TEST_F(PipelineTest, DuplicatesAndReplaysAreDroppedAndCounted) {
  Pipeline clean(paper_calibration(), "x", PipelineSettings{}), dirty(paper_calibration(), "x", PipelineSettings{});
  Collect want, got;
  int injected = 0;
  for (size_t i = 0; i < 60; ++i) {
    clean.on_block((*blocks_)[i], 0, want);
    dirty.on_block((*blocks_)[i], 0, got);
    if (i % 10 == 5) {  // the network duplicates the block
      dirty.on_block((*blocks_)[i], 0, got);
      ++injected;
    }
    if (i % 10 == 7) {  // a replay of an old block, and of the stream's first one (seq 0, old time)
      dirty.on_block((*blocks_)[i - 3], 0, got);
      dirty.on_block((*blocks_)[0], 0, got);
      injected += 2;
    }
    if (i % 10 == 9) {  // seq advancing but scans overlapping what was compensated
      pof::raw_block_t overlap = (*blocks_)[i];
      overlap.seq += 1000;
      dirty.on_block(overlap, 0, got);
      ++injected;
    }
  }
  ASSERT_EQ(got.angles.size(), want.angles.size());
  for (size_t k = 0; k < got.angles.size(); ++k) {
    ASSERT_EQ(got.angles[k].scan_index, want.angles[k].scan_index);
    ASSERT_EQ(got.angles[k].angle_deg, want.angles[k].angle_deg);
    ASSERT_EQ(got.angles[k].quality, want.angles[k].quality);
  }
  const auto st = dirty.status(0);
  EXPECT_EQ(st.duplicate_blocks, injected);
  EXPECT_EQ(st.lost_blocks, 0);
  EXPECT_EQ(st.lost_scans, 0);
  EXPECT_EQ(st.blocks, 60 + injected);
}

// A restarted pof-daqd numbers from 0 again and stamps with the current clock: a new stream, taken
// at once, with no loss counted; its first block replayed later is a duplicate.
TEST_F(PipelineTest, RestartIsSeqZeroWithALaterTime) {
  Pipeline p(paper_calibration(), "x", PipelineSettings{});
  Collect out;
  for (size_t i = 0; i < 50; ++i) p.on_block((*blocks_)[i], 0, out);
  std::vector<pof::raw_block_t> restarted;
  for (size_t i = 0; i < 5; ++i) {
    pof::raw_block_t b = (*blocks_)[i];
    b.utime = (*blocks_)[60 + i].utime;  // later than anything seen
    restarted.push_back(b);
  }
  const size_t before = out.angles.size();
  for (const auto& b : restarted) p.on_block(b, 0, out);
  EXPECT_EQ(out.angles.size(), before + 5 * kScansPerBlock);
  EXPECT_TRUE(out.angles[before].quality & pof::angle_t::QUALITY_SETTLING);  // the estimator restarted
  p.on_block(restarted[0], 0, out);  // replayed: not later than the last block taken
  const auto st = p.status(0);
  EXPECT_EQ(st.duplicate_blocks, 1);
  EXPECT_EQ(st.lost_blocks, 0);
  EXPECT_EQ(st.lost_scans, 0);
}

// A forged block far ahead (seq and first_scan near 2^62 and INT64_MAX): the loss counters saturate
// instead of wrapping negative, the real stream is dropped as stale for kResyncBlocks - 1 blocks
// and then taken again; blocks with negative or overflowing indices are rejected outright.
TEST_F(PipelineTest, ForgedNumbersSaturateAndTheStreamResumes) {
  constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
  Pipeline p(paper_calibration(), "x", PipelineSettings{});
  Collect out;
  for (size_t i = 0; i < 10; ++i) p.on_block((*blocks_)[i], 0, out);
  pof::raw_block_t far = (*blocks_)[10];
  far.seq = std::int64_t{1} << 62;  // a jump of 2^62
  far.first_scan = std::int64_t{1} << 62;
  p.on_block(far, 0, out);
  auto st = p.status(0);
  EXPECT_EQ(st.lost_blocks, (std::int64_t{1} << 62) - 10);
  EXPECT_EQ(st.lost_scans, (std::int64_t{1} << 62) - 10 * kScansPerBlock);

  pof::raw_block_t negative = (*blocks_)[11];
  negative.seq = -5;
  p.on_block(negative, 0, out);
  pof::raw_block_t overflowing = (*blocks_)[11];
  overflowing.first_scan = kMax - 3;
  p.on_block(overflowing, 0, out);
  pof::raw_block_t no_time = (*blocks_)[11];
  no_time.utime = kMax;
  p.on_block(no_time, 0, out);
  EXPECT_EQ(p.status(0).rejected_blocks, 3);

  // The real stream, now "behind" the forged block, is taken again after kResyncBlocks.
  size_t before = out.angles.size();
  size_t next = 11;
  for (; next < 11 + Pipeline::kResyncBlocks + 5; ++next) p.on_block((*blocks_)[next], 0, out);
  st = p.status(0);
  EXPECT_EQ(st.duplicate_blocks, Pipeline::kResyncBlocks - 1);
  EXPECT_EQ(out.angles.size(), before + size_t(6 * kScansPerBlock));  // the resync block and 5 more
  EXPECT_EQ(out.angles[before].scan_index, (*blocks_)[11 + Pipeline::kResyncBlocks - 1].first_scan);

  // A second forged jump, to INT64_MAX: the counters stop there, never wrap negative.
  far.seq = kMax - 1;
  far.first_scan = kMax - kScansPerBlock;
  p.on_block(far, 0, out);
  st = p.status(0);
  EXPECT_EQ(st.lost_blocks, kMax);
  EXPECT_EQ(st.lost_scans, kMax);
  before = out.angles.size();
  for (size_t k = 0; k < size_t(Pipeline::kResyncBlocks) + 2; ++k) p.on_block((*blocks_)[next++], 0, out);
  st = p.status(0);
  EXPECT_EQ(out.angles.size(), before + size_t(3 * kScansPerBlock));
  EXPECT_EQ(st.lost_blocks, kMax);
  EXPECT_EQ(st.lost_scans, kMax);
  EXPECT_EQ(st.duplicate_blocks, 2 * (Pipeline::kResyncBlocks - 1));
}

// The daemon's wiring in-process: blocks published on memq:// reach the pipeline through
// pof::bus::Receiver, and the outputs are those of direct calls, whatever else is on the channel:
// undecodable messages are counted by the receiver, duplicates by the pipeline.
TEST_F(PipelineTest, OverMemqTheOutputIsThatOfDirectCallsDespiteHostileTraffic) {
  lcm::LCM lc("memq://");
  ASSERT_TRUE(lc.good());
  Pipeline direct(paper_calibration(), "x", PipelineSettings{}), bused(paper_calibration(), "x", PipelineSettings{});
  Collect want, got;
  pof::bus::Receiver rx(lc, "memq://");
  rx.subscribe<pof::raw_block_t>("POF_RAW_LEFT_KNEE",
                                 [&](const pof::raw_block_t& b, const pof::bus::Delivery&) { bused.on_block(b, 0, got); });
  // A raw_block_t claiming 2^31-1 scans (std::bad_alloc in the generated decoder).
  pof::raw_block_t empty{};
  std::vector<unsigned char> bomb(static_cast<size_t>(empty.getEncodedSize()));
  empty.encode(bomb.data(), 0, int(bomb.size()));
  bomb[bomb.size() - 8] = 0x7f;
  for (size_t k = 1; k < 4; ++k) bomb[bomb.size() - 8 + k] = 0xff;
  int bombs = 0, dups = 0;
  for (size_t i = 0; i < 300; ++i) {
    direct.on_block((*blocks_)[i], 0, want);
    ASSERT_EQ(lc.publish("POF_RAW_LEFT_KNEE", &(*blocks_)[i]), 0);
    if (i % 50 == 3) {
      ASSERT_EQ(lc.publish("POF_RAW_LEFT_KNEE", bomb.data(), unsigned(bomb.size())), 0);
      ++bombs;
    }
    if (i % 50 == 7) {
      ASSERT_EQ(lc.publish("POF_RAW_LEFT_KNEE", &(*blocks_)[i]), 0);
      ++dups;
    }
    while (rx.handle(0) > 0) {
    }
  }
  ASSERT_EQ(got.angles.size(), want.angles.size());
  for (size_t i = 0; i < got.angles.size(); ++i) ASSERT_EQ(got.angles[i].angle_deg, want.angles[i].angle_deg);
  EXPECT_EQ(bused.status(0).lost_blocks, 0);
  EXPECT_EQ(bused.status(0).duplicate_blocks, dups);
  EXPECT_EQ(rx.stats().decode_errors, std::uint64_t(bombs));
}

// Every message LCM refuses is counted in the status. liblcm 1.3.1's memq:// never refuses one;
// its udpm:// refuses a channel name longer than LCM_MAX_CHANNEL_NAME_LENGTH, the refusal a test
// can provoke: the daemon's own sink publishes the angles on such a channel. (It also prints
// "LCM Error: channel name too long" once per message, hence the decimated output.)
TEST_F(PipelineTest, MessagesLcmRefusesAreCountedInTheStatus) {
  std::mt19937 rng(std::random_device{}());
  const std::string url = "udpm://239.255.76.67:" + std::to_string(20000 + rng() % 30000) + "?ttl=0";
  lcm::LCM lc(url);
  ASSERT_TRUE(lc.good()) << "no multicast route? " << url;
  std::vector<std::string> logged;
  pof::bus::ErrorLog errors([&](const std::string& line) { logged.push_back(line); });
  const std::string too_long = pof::bus::channel(pof::bus::Stream::kAngle, std::string(60, 'X'));
  ASSERT_GT(too_long.size(), std::size_t{LCM_MAX_CHANNEL_NAME_LENGTH});
  pof::bus::Publisher pub(lc, nullptr);
  pof::compensatord::LcmSink sink(pub, too_long, pof::bus::channel(pof::bus::Stream::kStats, "LEFT_KNEE"), errors);
  PipelineSettings ps;
  ps.output_rate_hz = 10;  // one angle per 20-scan block
  Pipeline p(paper_calibration(), "x", ps);
  for (size_t i = 0; i < 8; ++i) p.on_block((*blocks_)[i], 0, sink);
  pof::compensator_status_t st = p.status(0);
  EXPECT_EQ(st.angles, 8);  // produced (seq advanced), none published
  EXPECT_EQ(st.publish_failures, 8);
  ASSERT_EQ(logged.size(), 1u);  // the first in full, the rest summarised later (rate-limited)
  EXPECT_NE(logged[0].find(too_long), std::string::npos) << logged[0];
  // The daemon's status message itself, when refused, counts in the next one.
  p.note_publish_failure();
  EXPECT_EQ(p.status(0).publish_failures, 9);
  // A sink that publishes counts nothing.
  Pipeline q(paper_calibration(), "x", ps);
  pof::compensatord::LcmSink fine(pub, pof::bus::channel(pof::bus::Stream::kAngle, "LEFT_KNEE"),
                                  pof::bus::channel(pof::bus::Stream::kStats, "LEFT_KNEE"), errors);
  for (size_t i = 0; i < 8; ++i) q.on_block((*blocks_)[i], 0, fine);
  EXPECT_EQ(q.status(0).angles, 8);
  EXPECT_EQ(q.status(0).publish_failures, 0);
}

}  // namespace

// The estimator's fixed lag (CompensatorSettings::estimator_lag_s): each message describes the scan
// L back, whole: its utime, scan_index and reference angle are that scan's, and its angle is the one
// `pof compensate` puts on that scan's row with the same lag.
TEST_F(PipelineTest, AFixedLagPublishesEachScanLLateWithItsOwnTimeAndReference) {
  auto f = paper_calibration();
  pof::core::DynamicModel m;
  m.degree = 1;
  m.poly = {2.4, -1.0, 0, 0, 0, 0};
  m.n_operators = 2;
  m.threshold_deg = {1.0, 5.0};
  m.weight_v_per_deg = {0.001, 0.001};
  f.cal.dynamic = m;
  f.cal.active = pof::core::ModelKind::kDynamic;
  f.cal.estimator = pof::core::EstimatorNoise{0.0015, 300};
  constexpr int kLag = 5;
  PipelineSettings s;
  s.compensator.estimator_lag_s = kLag / 200.0;
  Pipeline p(f, "lag.toml", s);
  Collect out;
  for (const auto& b : *blocks_) p.on_block(b, 0, out);
  const auto [t, sv, r, a] = offline_inputs();
  const pof::core::OfflineResult off = pof::core::compensate_recording(t, sv, r, a, f.cal, s.compensator);
  const auto n = Eigen::Index(blocks_->size() * kScansPerBlock);
  ASSERT_EQ(Eigen::Index(out.angles.size()), n);
  for (Eigen::Index j = kLag; j < n; ++j) {
    const auto& msg = out.angles[size_t(j)];
    const Eigen::Index scan = j - kLag;
    ASSERT_EQ(msg.scan_index, scan);
    ASSERT_EQ(msg.utime, kEpochUtime + scan * 5000) << j;  // 200 Hz from the epoch
    ASSERT_EQ(msg.angle_ref_deg, float(a[scan])) << j;
    if (std::isnan(off.angle_deg[scan])) ASSERT_TRUE(std::isnan(msg.angle_deg)) << j;
    else ASSERT_EQ(msg.angle_deg, float(off.angle_deg[scan])) << j;
    ASSERT_EQ(std::isfinite(msg.angle_sigma_deg), std::isfinite(msg.angle_deg)) << j;
  }
  for (int j = 0; j < kLag; ++j) EXPECT_TRUE(std::isnan(out.angles[size_t(j)].angle_deg));
}
