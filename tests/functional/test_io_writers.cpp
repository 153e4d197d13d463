// The recording writers on real temporary files: CSV numbers read back exactly, LCM logs decode to
// the raw_block_t contract (channels, units, flags, times, scan indices), output is atomic (a failed
// or abandoned write leaves the previous file untouched) and simulator output is byte-deterministic.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <pof/raw_block_t.hpp>

#include "pof/io/csv_writer.hpp"
#include "pof/base/errors.hpp"
#include "pof/io/lcmlog_writer.hpp"
#include "pof/sim/scenario.hpp"
#include "pof/sim/simulator.hpp"

namespace fs = std::filesystem;

namespace {

class Writers : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("pof_writers_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  static std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream o;
    o << in.rdbuf();
    return o.str();
  }
  std::size_t files_in_dir() const {
    return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir_), fs::directory_iterator{}));
  }
  fs::path dir_;
};

std::vector<pof::io::RecordingRow> simulate(double seconds, std::uint64_t seed) {
  pof::sim::Scenario s = pof::sim::builtin_scenario("realistic");
  s.duration_s = seconds;
  pof::sim::Simulator sim(s, seed, 0);
  std::vector<pof::sim::Scan> scans(static_cast<std::size_t>(seconds * 200) + 1);
  scans.resize(sim.next(scans));
  std::vector<pof::io::RecordingRow> rows;
  for (const auto& x : scans) rows.push_back({x.t_s, x.sensor_v, x.reference_v, x.pot_v, x.angle_ref_deg, x.angle_true_deg, x.over_range != 0});
  return rows;
}

TEST_F(Writers, CsvRoundTripsExactly) {
  const auto rows = simulate(5, 1);
  const fs::path p = dir_ / "a.csv";
  {
    pof::io::CsvColumns cols;
    cols.pot_v = true;
    pof::io::CsvWriter w(p, cols);
    for (const auto& r : rows) w.write(r);
    w.commit();
  }
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "t_s,sensor_v,reference_v,angle_ref_deg,pot_v,angle_true_deg");
  std::size_t i = 0;
  while (std::getline(in, line)) {
    ASSERT_LT(i, rows.size());
    std::vector<double> v;
    const char* c = line.c_str();
    char* end = nullptr;
    for (;;) {
      v.push_back(std::strtod(c, &end));
      if (*end != ',') break;
      c = end + 1;
    }
    ASSERT_EQ(*end, '\0');
    ASSERT_EQ(v.size(), 6u);
    EXPECT_EQ(v[0], rows[i].t_s);
    EXPECT_EQ(v[1], rows[i].sensor_v);
    EXPECT_EQ(v[2], rows[i].reference_v);
    EXPECT_EQ(v[3], rows[i].angle_ref_deg);
    EXPECT_EQ(v[4], rows[i].pot_v);
    EXPECT_EQ(v[5], rows[i].angle_true_deg);  // unquantised ground truth, 17 digits if needed
    ++i;
  }
  EXPECT_EQ(i, rows.size());
}

TEST_F(Writers, CsvDefaultHeaderAndRecordingOverload) {
  pof::io::Recording rec;
  rec.t_s = Eigen::VectorXd::LinSpaced(3, 0, 0.01);
  rec.sensor_v = Eigen::VectorXd::Constant(3, 4.25);
  rec.reference_v = Eigen::VectorXd::Constant(3, 4.0);
  rec.pot_v = Eigen::VectorXd::Constant(3, 1.5);
  const fs::path p = dir_ / "rec.csv";
  pof::io::write_csv(p, rec);
  EXPECT_EQ(slurp(p), "t_s,sensor_v,reference_v,pot_v\n0,4.25,4,1.5\n0.005,4.25,4,1.5\n0.01,4.25,4,1.5\n");
  const fs::path q = dir_ / "sim.csv";
  {
    pof::io::CsvWriter w(q);
    w.write({0.005, 1, 2, 3, 4, 5, false});
    w.commit();
  }
  EXPECT_EQ(slurp(q), "t_s,sensor_v,reference_v,angle_ref_deg,angle_true_deg\n0.005,1,2,4,5\n");
}

TEST_F(Writers, AbandonedOrFailedWritesLeaveTheOldFile) {
  const fs::path p = dir_ / "keep.csv";
  { std::ofstream(p) << "good data\n"; }
  {
    pof::io::CsvWriter w(p);
    w.write({0, 1, 2, 3, 4, 5, false});
    // destroyed without commit (e.g. an exception in the simulation): nothing replaced
  }
  EXPECT_EQ(slurp(p), "good data\n");
  {
    pof::io::LcmLogWriter w(dir_ / "keep.lcmlog", {});
    w.write({0, 1, 2, 3, 4, 5, false});
  }
  EXPECT_FALSE(fs::exists(dir_ / "keep.lcmlog"));
  EXPECT_EQ(files_in_dir(), 1u) << "temporary files are removed";
  EXPECT_THROW(pof::io::CsvWriter(dir_ / "no" / "such" / "dir.csv"), pof::IoError);
}

TEST_F(Writers, LcmLogDecodesToTheRawBlockContract) {
  const auto rows = simulate(2.01, 1);  // 403 scans: 20 full blocks + one of 3
  ASSERT_EQ(rows.size(), 402u);
  const fs::path p = dir_ / "a.lcmlog";
  pof::io::LcmLogOptions o;
  o.sensor_id = "SIM_REALISTIC";
  o.scan_rate_hz = 200;
  pof::io::LcmLogWriter w(p, o);
  for (const auto& r : rows) w.write(r);
  w.commit();
  EXPECT_EQ(w.blocks(), 21);

  lcm::LogFile log(p.string(), "r");
  ASSERT_TRUE(log.good());
  std::int64_t seq = 0, next_scan = 0;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    EXPECT_EQ(ev->channel, "POF_RAW");
    pof::raw_block_t m;
    ASSERT_EQ(m.decode(ev->data, 0, ev->datalen), ev->datalen);
    EXPECT_EQ(m.seq, seq);
    EXPECT_EQ(m.first_scan, next_scan);
    EXPECT_EQ(m.sensor_id, "SIM_REALISTIC");
    EXPECT_EQ(m.scan_rate_hz, 200);
    ASSERT_EQ(m.n_channels, 5);
    EXPECT_EQ(m.channel_names, (std::vector<std::string>{"sensor", "reference", "pot", "angle_ref", "angle_true"}));
    EXPECT_EQ(m.channel_units, (std::vector<std::string>{"V", "V", "V", "deg", "deg"}));
    EXPECT_TRUE(m.flags & pof::raw_block_t::FLAG_SIMULATED);
    EXPECT_EQ(m.n_scans, seq < 20 ? 20 : 2);
    const auto k0 = static_cast<std::size_t>(m.first_scan);
    EXPECT_EQ(m.utime, pof::io::kDefaultEpochUtime + std::llround(rows[k0].t_s * 1e6));
    EXPECT_EQ(m.publish_utime, m.utime + (m.n_scans - 1) * 5000);
    EXPECT_EQ(ev->timestamp, m.publish_utime);
    for (int k = 0; k < m.n_scans; ++k) {
      const auto& r = rows[k0 + static_cast<std::size_t>(k)];
      const auto& v = m.volts[static_cast<std::size_t>(k)];
      EXPECT_EQ(v[0], static_cast<float>(r.sensor_v));
      EXPECT_EQ(v[1], static_cast<float>(r.reference_v));
      EXPECT_EQ(v[2], static_cast<float>(r.pot_v));
      EXPECT_EQ(v[3], static_cast<float>(r.angle_ref_deg));
      EXPECT_EQ(v[4], static_cast<float>(r.angle_true_deg));
    }
    next_scan += m.n_scans;
    ++seq;
  }
  EXPECT_EQ(seq, 21);
  EXPECT_EQ(next_scan, 402);
}

TEST_F(Writers, OverRangeScansFlagTheirBlock) {
  pof::io::LcmLogOptions o;
  o.block_scans = 2;
  pof::io::LcmLogWriter w(dir_ / "o.lcmlog", o);
  w.write({0, 1, 1, 1, 0, 0, false});
  w.write({0.005, 1, 1, 1, 0, 0, false});
  w.write({0.010, 9.995, 1, 1, 0, 0, true});
  w.commit();
  lcm::LogFile log((dir_ / "o.lcmlog").string(), "r");
  std::vector<std::int32_t> flags;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    pof::raw_block_t m;
    m.decode(ev->data, 0, ev->datalen);
    flags.push_back(m.flags);
  }
  ASSERT_EQ(flags.size(), 2u);
  EXPECT_EQ(flags[0], pof::raw_block_t::FLAG_SIMULATED);
  EXPECT_EQ(flags[1], int32_t{pof::raw_block_t::FLAG_SIMULATED} | int32_t{pof::raw_block_t::FLAG_OVER_RANGE});
}

TEST_F(Writers, SameSeedSameBytesDifferentSeedDifferentBytes) {
  auto write_both = [&](std::uint64_t seed, const std::string& tag) {
    const auto rows = simulate(30, seed);
    pof::io::CsvWriter c(dir_ / (tag + ".csv"));
    pof::io::LcmLogWriter l(dir_ / (tag + ".lcmlog"), {});
    for (const auto& r : rows) c.write(r), l.write(r);
    c.commit();
    l.commit();
  };
  write_both(5, "a");
  write_both(5, "b");
  write_both(6, "c");
  EXPECT_EQ(slurp(dir_ / "a.csv"), slurp(dir_ / "b.csv"));
  EXPECT_EQ(slurp(dir_ / "a.lcmlog"), slurp(dir_ / "b.lcmlog"));
  EXPECT_NE(slurp(dir_ / "a.csv"), slurp(dir_ / "c.csv"));
  EXPECT_NE(slurp(dir_ / "a.lcmlog"), slurp(dir_ / "c.lcmlog"));
}

}  // namespace
