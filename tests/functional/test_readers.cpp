// Recording readers (CSV, LCM log), the calibration TOML and atomic writes, on temporary files.
#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csignal>
#include <thread>

#include <lcm/lcm-cpp.hpp>
#include <pof/raw_block_t.hpp>

#include "pof/testing/paper_protocol.hpp"
#include "pof/core/calibration.hpp"
#include "pof/core/offline.hpp"
#include "pof/io/atomic_file.hpp"
#include "pof/io/calibration_file.hpp"
#include "pof/base/errors.hpp"
#include "pof/io/lcmlog_scan.hpp"
#include "pof/io/recording_reader.hpp"
#include "pof/base/text_file.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using pof::ConfigError;
using pof::DataError;

namespace {

using pof::test::TempDir;

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const pof::Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(CsvReader, ReadsColumnsByNameIgnoringExtrasCommentsAndCrlf) {
  TempDir d;
  const auto p = d.file("a.csv",
                        "# written by a test\r\n"
                        "angle_true_deg,reference_v,extra,t_s,sensor_v,angle_ref_deg\r\n"
                        "1.5,4.0,x,0.000,3.0,1.0\r\n"
                        "\r\n"
                        "2.5,4.1,y,0.005,nan,2.0\r\n");
  const auto r = pof::io::read_csv(p);
  ASSERT_EQ(r.size(), 2);
  EXPECT_DOUBLE_EQ(r.t_s(1), 0.005);
  EXPECT_DOUBLE_EQ(r.reference_v(1), 4.1);
  EXPECT_TRUE(std::isnan(r.sensor_v(1))) << "a dropout the compensator flags";
  EXPECT_DOUBLE_EQ(r.angle_ref_deg(0), 1.0);
  EXPECT_DOUBLE_EQ(r.angle_true_deg(1), 2.5);
  EXPECT_EQ(r.pot_v.size(), 0);
  const auto q = pof::io::read_csv(d.file("b.csv", "t_s,sensor_v,reference_v,pot_v\n0,1,2,3\n"));
  EXPECT_DOUBLE_EQ(q.pot_v(0), 3);
  EXPECT_EQ(q.angle_ref_deg.size(), 0);
}

TEST(CsvReader, BadInputNamesFileLineAndColumn) {
  TempDir d;
  const std::string h = "t_s,sensor_v,reference_v,angle_ref_deg\n";
  EXPECT_NE(error_of([&] { pof::io::read_csv(d.file("a.csv", h + "0,1,2,3\n0.1,1,zz,3\n")); }).find("a.csv:3: column reference_v: expected a number, got 'zz'"), std::string::npos);
  EXPECT_NE(error_of([&] { pof::io::read_csv(d.file("b.csv", h + "0,1,2,3\n0.1,1,2\n")); }).find("b.csv:3: expected 4 fields"), std::string::npos);
  EXPECT_NE(error_of([&] { pof::io::read_csv(d.file("c.csv", h + "0,1,2,3\n0.1,1,2,3")); }).find("c.csv:3: last line has no newline"), std::string::npos);
  EXPECT_NE(error_of([&] { pof::io::read_csv(d.file("d.csv", h + "0.1,1,2,3\n0.1,1,2,3\n")); }).find("d.csv:3: column t_s: time 0.1 does not increase"), std::string::npos);
  EXPECT_NE(error_of([&] { pof::io::read_csv(d.file("e.csv", "t_s,sensor_v,angle_ref_deg\n")); }).find("e.csv:1: header has no column 'reference_v'"), std::string::npos);
  EXPECT_NE(error_of([&] { pof::io::read_csv(d.file("f.csv", "")); }).find("f.csv:1: empty file"), std::string::npos);
  EXPECT_NE(error_of([&] { pof::io::read_csv(d.file("g.csv", h)); }).find("no data rows"), std::string::npos);
  EXPECT_NE(error_of([&] { pof::io::read_csv(d.file("h.csv", "t_s,sensor_v,reference_v\n")); }).find("neither 'angle_ref_deg' nor 'pot_v'"), std::string::npos);
  EXPECT_NE(error_of([&] { pof::io::read_csv(d.file("i.csv", h + "0,1,inf,3\n")); }).find("i.csv:2: column reference_v: expected a finite number"), std::string::npos);
  EXPECT_THROW(pof::io::read_csv(d.path("missing.csv")), pof::NoInputError);
}

// Property: any single corrupted byte or any truncation of a valid file either still parses or is
// a DataError naming the file and a line; never a crash or another exception.
TEST(CsvReader, CorruptedAndTruncatedFilesAreDataErrorsWithALine) {
  TempDir d;
  std::string good = "t_s,sensor_v,reference_v,angle_ref_deg,angle_true_deg\n";
  for (int i = 0; i < 200; ++i) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%.3f,%.5f,%.5f,%.4f,%.4f\n", i * 0.005, 4.3 - i * 0.001, 4.0, i * 0.05, i * 0.05);
    good += buf;
  }
  std::mt19937_64 rng(42);
  std::uniform_int_distribution<std::size_t> pos(0, good.size() - 1);
  const char junk[] = {'x', ',', '\n', '-', '.', 'e', ' ', '\0', '9'};
  int errors = 0;
  for (int trial = 0; trial < 150; ++trial) {
    std::string s = good;
    if (trial % 2 == 0) s[pos(rng)] = junk[trial % static_cast<int>(sizeof junk)];
    else s.resize(pos(rng));
    const auto p = d.file("x.csv", s);
    try {
      (void)pof::io::read_csv(p);
    } catch (const DataError& e) {
      ++errors;
      EXPECT_EQ(std::string(e.what()).rfind(p + ":", 0), 0u) << e.what();
      EXPECT_EQ(e.code(), 65);
    }
  }
  EXPECT_GT(errors, 100);
}

namespace {

void write_block(lcm::LogFile& log, const std::string& channel, std::int64_t utime, std::int64_t first_scan,
                 const std::vector<std::string>& names, int n_scans, double offset) {
  pof::raw_block_t b{};
  b.utime = utime;
  b.publish_utime = utime + 1000;
  b.seq = first_scan / n_scans;
  b.first_scan = first_scan;
  b.scan_rate_hz = 200;
  b.sensor_id = "LEFT_KNEE";
  b.n_channels = static_cast<std::int16_t>(names.size());
  b.channel_names = names;
  b.channel_units.assign(names.size(), "V");
  b.n_scans = n_scans;
  b.volts.assign(static_cast<std::size_t>(n_scans), std::vector<float>(names.size()));
  for (int k = 0; k < n_scans; ++k)
    for (std::size_t c = 0; c < names.size(); ++c)
      b.volts[static_cast<std::size_t>(k)][c] = static_cast<float>(offset + static_cast<double>(c) + 0.001 * static_cast<double>(first_scan + k));
  b.flags = pof::raw_block_t::FLAG_SIMULATED;
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(b.getEncodedSize()));
  b.encode(buf.data(), 0, static_cast<int>(buf.size()));
  lcm::LogEvent ev{};
  ev.eventnum = 0;
  ev.timestamp = utime;
  ev.channel = channel;
  ev.datalen = static_cast<std::int32_t>(buf.size());
  ev.data = buf.data();
  ASSERT_EQ(log.writeEvent(&ev), 0);
}

}  // namespace

TEST(LcmLogReader, MapsChannelsByNameAndTimesFromTheBlocks) {
  TempDir d;
  const auto p = d.path("rec.lcmlog");
  {
    lcm::LogFile log(p, "w");
    ASSERT_TRUE(log.good());
    const std::vector<std::string> names = {"pot", "reference", "extra", "sensor", "angle_true"};
    for (int b = 0; b < 5; ++b) {
      write_block(log, "POF_RAW", 1'700'000'000'000'000 + b * 50'000, b * 10, names, 10, 0.0);
      write_block(log, "POF_DAQ_STATUS", 1'700'000'000'000'000 + b * 50'000, 0, {"x"}, 1, 0.0);  // not a raw block: other channel, skipped
    }
  }
  const auto r = pof::io::read_recording(p);  // sniffed as an LCM log
  ASSERT_EQ(r.size(), 50);
  EXPECT_NEAR(r.t_s(0), 0.0, 1e-12);
  EXPECT_NEAR(r.t_s(49), 0.245, 1e-9);
  EXPECT_NEAR(r.pot_v(13), 0.0 + 0.013, 1e-6);
  EXPECT_NEAR(r.reference_v(13), 1.0 + 0.013, 1e-6);
  EXPECT_NEAR(r.sensor_v(13), 3.0 + 0.013, 1e-6);
  EXPECT_NEAR(r.angle_true_deg(13), 4.0 + 0.013, 1e-6);
  EXPECT_EQ(r.angle_ref_deg.size(), 0);

  // Truncated: every cut inside the last event is a DataError naming a byte offset.
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string all = ss.str();
  for (std::size_t cut : {all.size() - 1, all.size() - 30, all.size() - 200}) {
    const auto t = d.file("cut.lcmlog", all.substr(0, cut));
    const std::string e = error_of([&] { pof::io::read_lcmlog(t); });
    EXPECT_NE(e.find(t + ": damaged LCM log: first damage at byte "), std::string::npos) << e;
    EXPECT_NE(e.find("at least 1 event lost"), std::string::npos) << e;
  }
  // Garbage between events.
  std::string g = all;
  g.insert(200, "garbage");
  const std::string e = error_of([&] { pof::io::read_lcmlog(d.file("garbage.lcmlog", g)); });
  EXPECT_NE(e.find("damaged LCM log: first damage at byte "), std::string::npos) << e;
  EXPECT_NE(e.find("1 damaged region (7 bytes) skipped"), std::string::npos) << e;
}

TEST(LcmLogReader, MissingChannelsAreNamed) {
  TempDir d;
  const auto p = d.path("rec.lcmlog");
  {
    lcm::LogFile log(p, "w");
    write_block(log, "POF_RAW_LEFT_KNEE", 1'000'000, 0, {"sensor", "pot"}, 4, 0.0);
  }
  const std::string e = error_of([&] { pof::io::read_lcmlog(p); });
  EXPECT_NE(e.find("[sensor,pot]; expected \"sensor\" and \"reference\""), std::string::npos) << e;
  const auto q = d.path("order.lcmlog");
  {
    lcm::LogFile log(q, "w");
    write_block(log, "POF_RAW", 2'000'000, 10, {"sensor", "reference", "angle_ref"}, 10, 0.0);
    write_block(log, "POF_RAW", 1'950'000, 0, {"sensor", "reference", "angle_ref"}, 10, 0.0);
  }
  const std::string e3 = error_of([&] { pof::io::read_lcmlog(q); });
  EXPECT_NE(e3.find("event 1 on POF_RAW (byte "), std::string::npos) << e3;
  EXPECT_NE(e3.find("block utime 1950000 does not follow"), std::string::npos) << e3;
  const std::string e2 = error_of([&] { pof::io::read_lcmlog(p, "POF_RAW_RIGHT_KNEE"); });
  EXPECT_NE(e2.find("no pof.raw_block_t events on channel POF_RAW_RIGHT_KNEE"), std::string::npos) << e2;
}

namespace {

std::string slurp(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A log of `n` raw blocks on POF_RAW, as its bytes.
std::string raw_log(const TempDir& d, int n) {
  const auto p = d.path("raw.lcmlog");
  {
    lcm::LogFile log(p, "w");
    for (int b = 0; b < n; ++b)
      write_block(log, "POF_RAW", 1'000'000 + b * 50'000, b * 10, {"sensor", "reference", "angle_ref"}, 10, 0.0);
  }
  return slurp(p);
}

// Writes `content` into a new FIFO at `path` from a thread (the reader opens the other end).
struct FifoWriter {
  std::thread t;
  FifoWriter(const std::string& path, std::string content) {
    EXPECT_EQ(::mkfifo(path.c_str(), 0600), 0);
    t = std::thread([path, content = std::move(content)] {
      const int fd = ::open(path.c_str(), O_WRONLY);
      if (fd < 0) return;
      std::size_t done = 0;
      while (done < content.size()) {
        const ssize_t w = ::write(fd, content.data() + done, content.size() - done);
        if (w <= 0) break;  // the reader stopped early (EPIPE)
        done += static_cast<std::size_t>(w);
      }
      ::close(fd);
    });
  }
  ~FifoWriter() { t.join(); }
};

}  // namespace

TEST(LcmLogReader, HugeDataLengthIsADataErrorWithOffsetAndCounts) {
  TempDir d;
  std::string log = raw_log(d, 10);
  // Event 4's data length (bytes 24..27 of its header) set to 0x7fffffff: liblcm's reader crashed.
  const std::size_t ev = log.size() / 10 * 4;
  ASSERT_EQ(static_cast<unsigned char>(log[ev]), 0xED);
  log[ev + 24] = '\x7f';
  log[ev + 25] = log[ev + 26] = log[ev + 27] = '\xff';
  const auto p = d.file("huge.lcmlog", log);
  const std::string e = error_of([&] { pof::io::read_recording(p); });
  EXPECT_EQ(e, p + ": damaged LCM log: first damage at byte " + std::to_string(ev) +
                   ": implausible data length 2147483647; 1 damaged region (" + std::to_string(log.size() / 10) +
                   " bytes) skipped, at least 1 event lost; 0 events not decodable; 9 complete events read");
}

TEST(LcmLogReader, PayloadsThatDoNotDecodeAreCountedDamage) {
  TempDir d;
  std::string log = raw_log(d, 6);
  const std::size_t ev = log.size() / 6 * 2;
  log[ev + 28 + 7 + 3] ^= 0x10;  // a fingerprint byte of event 2's raw_block_t
  const std::string e = error_of([&] { pof::io::read_lcmlog(d.file("fp.lcmlog", log)); });
  EXPECT_NE(e.find("first damage at byte " + std::to_string(ev) + ": event 2 on channel POF_RAW: not a pof.raw_block_t"),
            std::string::npos) << e;
  EXPECT_NE(e.find("1 event not decodable; 6 complete events read"), std::string::npos) << e;
}

TEST(RecordingReaders, StreamsAreReadOnceAndBounded) {
  std::signal(SIGPIPE, SIG_IGN);
  TempDir d;
  // CSV and LCM log through a pipe: the sniffed first bytes are not lost.
  {
    FifoWriter w(d.path("csv.fifo"), "t_s,sensor_v,reference_v,angle_ref_deg\n0,1,2,3\n0.1,1,2,3\n");
    EXPECT_EQ(pof::io::read_recording(d.path("csv.fifo")).size(), 2);
  }
  {
    FifoWriter w(d.path("log.fifo"), raw_log(d, 5));
    EXPECT_EQ(pof::io::read_recording(d.path("log.fifo")).size(), 50);
  }
  // A stream longer than the bound is refused once it has read past it, not read to its end.
  {
    std::string big = raw_log(d, 1);
    big.resize(3u << 20, 'x');
    FifoWriter w(d.path("big.fifo"), big);
    const std::string e = error_of([&] { pof::io::LcmLogReader log(d.path("big.fifo"), 1u << 20); });
    EXPECT_NE(e.find("not a regular file and longer than 1 MiB"), std::string::npos) << e;
  }
  // Endless devices: refused quickly, the message bounded.
  const std::string csv = error_of([&] { pof::io::read_recording("/dev/zero"); });
  EXPECT_EQ(csv, "/dev/zero:1: line longer than 65536 bytes (starts '"
                 "\\x00\\x00\\x00\\x00\\x00\\x00\\x00\\x00\\x00\\x00\u2026'): not a CSV recording");
  const std::string lcm = error_of([&] { pof::io::read_lcmlog("/dev/zero"); });
  EXPECT_EQ(lcm, "/dev/zero: byte 0: not an LCM log (bad sync word 0x00000000 (expected 0xEDA1DA01)); stopped reading "
                 "this device after 28 bytes");
  const std::string cal = error_of([&] { pof::io::load_calibration("/dev/zero"); });
  EXPECT_EQ(cal, "/dev/zero: longer than 1024 KiB: not a calibration file");
}

TEST(CsvReader, LongLinesAreErrorsNamingFileAndLine) {
  TempDir d;
  const std::string h = "t_s,sensor_v,reference_v,angle_ref_deg\n0,1,2,3\n";
  const auto p = d.file("long.csv", h + std::string(200'000, '9') + "\n");
  const std::string e = error_of([&] { pof::io::read_csv(p); });
  EXPECT_EQ(e.rfind(p + ":3: line longer than 65536 bytes (starts '9999", 0), 0u) << e;
  EXPECT_LT(e.size(), p.size() + 150);
  // A header with megabytes of fields is quoted in 40 bytes.
  const auto q = d.file("wide.csv", std::string(60'000, 'a') + "\n0\n");
  const std::string e2 = error_of([&] { pof::io::read_csv(q); });
  EXPECT_NE(e2.find("got '" + std::string(40, 'a') + "\u2026')"), std::string::npos) << e2.substr(0, 300);
  EXPECT_LT(e2.size(), q.size() + 200);
  // Exactly at the bound is still a line.
  const auto r = d.file("edge.csv", h + "#" + std::string(pof::io::kMaxCsvLineBytes - 1, 'c') + "\n");
  EXPECT_EQ(pof::io::read_csv(r).size(), 1);
}

TEST(OutputGuard, AnOutputThatIsAnInputIsAUsageError) {
  TempDir d;
  const std::string in = d.file("run.csv", "data");
  ASSERT_EQ(::symlink(in.c_str(), d.path("link.csv").c_str()), 0);
  ASSERT_EQ(::link(in.c_str(), d.path("hard.csv").c_str()), 0);
  const std::filesystem::path dotted = std::filesystem::path(d.path()) / "." / "run.csv";
  for (const std::string& out : {in, d.path("link.csv"), d.path("hard.csv"), dotted.string()}) {
    try {
      pof::io::refuse_output_over_input({{"recording", in}}, {{"-o", out}});
      ADD_FAILURE() << out << " accepted";
    } catch (const pof::UsageError& e) {
      EXPECT_EQ(e.code(), 2);
      EXPECT_NE(std::string(e.what()).find("-o " + out + ": is the same file as the input recording " + in), std::string::npos) << e.what();
    }
  }
  // Other files, standard output and options not given are fine; two outputs may not collide.
  pof::io::refuse_output_over_input({{"recording", in}, {"--pot-cal", ""}}, {{"-o", d.path("cal.toml")}, {"--csv", "-"}, {"--json", "-"}});
  EXPECT_THROW(pof::io::refuse_output_over_input({{"recording", in}}, {{"--csv", d.path("x")}, {"--json", d.path("./x")}}),
               pof::UsageError);
  // Two outputs may share a character device; not a pipe, whose reader would get them run together.
  EXPECT_NO_THROW(pof::io::refuse_output_over_input({{"recording", in}}, {{"--csv", "/dev/null"}, {"--json", "/dev/null"}}));
  ASSERT_EQ(::mkfifo(d.path("fifo").c_str(), 0600), 0);
  EXPECT_THROW(pof::io::refuse_output_over_input({{"recording", in}}, {{"--csv", d.path("fifo")}, {"--json", d.path("fifo")}}),
               pof::UsageError);
  EXPECT_EQ(slurp(in), "data");
}

namespace {

const pof::core::CalibrationResult& fitted() {
  static const auto r = [] {
    const auto g = pof::testing::paper_recording();
    return pof::core::calibrate(g.t_s, g.sensor_v, g.reference_v, g.angle_ref_deg);
  }();
  return r;
}

// The text with the first line that starts with line_start replaced (removed if replacement is "").
std::string replace_line(const std::string& text, const std::string& line_start, const std::string& replacement) {
  std::istringstream in(text);
  std::string out;
  bool done = false;
  for (std::string l; std::getline(in, l);) {
    if (!done && l.rfind(line_start, 0) == 0) {
      done = true;
      if (replacement.empty()) continue;
      l = replacement;
    }
    out += l + "\n";
  }
  return out;
}

}  // namespace

TEST(CalibrationFile, RoundTripsExactly) {
  auto f = pof::io::make_calibration_file(fitted(), "LEFT \"knee\"", "cal.csv", "2026-11-21T00:00:00Z");
  f.potentiometer = pof::core::PotentiometerCalibration{18.0, 0.1, {{0, 0.5}, {90, -0.5}}};
  const auto g = pof::io::parse_calibration(pof::io::to_toml(f), "mem.toml");
  EXPECT_EQ(g.sensor_id, "LEFT \"knee\"");
  EXPECT_EQ(g.cal.model.c1, f.cal.model.c1);
  EXPECT_EQ(g.cal.model.extension.c8, f.cal.model.extension.c8);
  EXPECT_EQ(g.cal.reference_level_v, f.cal.reference_level_v);
  EXPECT_EQ(g.cal.velocity_max_rad_s, f.cal.velocity_max_rad_s);
  EXPECT_EQ(g.quality.n_velocity_tests, 9);
  ASSERT_TRUE(g.potentiometer);
  EXPECT_EQ(g.potentiometer->offsets.size(), 2u);
  EXPECT_EQ(g.equation_flexion, f.equation_flexion);
}

// Property: removing any one required key of a valid file is a ConfigError that names that key.
TEST(CalibrationFile, EveryMissingKeyIsNamed) {
  const auto text = pof::io::to_toml(pof::io::make_calibration_file(fitted(), "S", "cal.csv", "2026-11-21T00:00:00Z"));
  std::istringstream in(text);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  std::string table;
  int checked = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    if (!l.empty() && l[0] == '[') {
      table = l.substr(1, l.find(']') - 1);
      continue;
    }
    const auto eq = l.find(" = ");
    if (l.empty() || l[0] == '#' || eq == std::string::npos || table == "equations") continue;
    const std::string key = (table.empty() ? "" : table + ".") + l.substr(0, eq);
    std::string mutilated;
    for (std::size_t j = 0; j < lines.size(); ++j)
      if (j != i) mutilated += lines[j] + "\n";
    try {
      (void)pof::io::parse_calibration(mutilated, "cal.toml");
      ADD_FAILURE() << "accepted without " << key;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("key '" + key + "'"), std::string::npos) << e.what();
      EXPECT_EQ(e.code(), 78);
    }
    ++checked;
  }
  EXPECT_GE(checked, 30);
}

TEST(CalibrationFile, InvalidValuesAreNamed) {
  const auto text = pof::io::to_toml(pof::io::make_calibration_file(fitted(), "S", "cal.csv", "2026-11-21T00:00:00Z"));
  auto with = [&](const std::string& line_start, const std::string& replacement) {
    return error_of([&] { pof::io::parse_calibration(replace_line(text, line_start, replacement), "cal.toml"); });
  };
  EXPECT_NE(with("c1 = ", "c1 = -1.0").find("key 'model.c1': expected a number > 0"), std::string::npos);
  EXPECT_NE(with("c2 = ", "c2 = inf").find("key 'model.c2': expected a finite number"), std::string::npos);
  EXPECT_NE(with("c3 = ", "c3 = [1]").find("key 'model.flexion.c3': expected a number, got an array"), std::string::npos);
  EXPECT_NE(with("c4 = ", "c4 = -5.0").find("key 'model.flexion.c4': f2 gives a"), std::string::npos);
  EXPECT_NE(with("angle_max_deg", "angle_max_deg = -5.0").find("key 'range.angle_max_deg'"), std::string::npos);
  EXPECT_NE(with("reference_level_v", "reference_level_v = 0").find("key 'reference_level_v': expected a number > 0"), std::string::npos);
  EXPECT_NE(with("n_holds", "n_holds = 2.5").find("key 'fit_quality.n_holds': expected an integer"), std::string::npos);
  EXPECT_NE(with("sensor_id", "sensor_id = 3").find("key 'sensor_id': expected a string"), std::string::npos);
  const std::string pot = text + "\n[potentiometer]\ndeg_per_volt = 18.0\nzero_v = 0.0\noffsets = [[10.0, 1.0], [5.0, 0.0]]\n";
  EXPECT_NE(error_of([&] { pof::io::parse_calibration(pot, "cal.toml"); }).find("key 'potentiometer.offsets[1]': angles must increase"), std::string::npos);
}

namespace {

pof::io::CalibrationFile with_dynamic_model() {
  auto f = pof::io::make_calibration_file(fitted(), "S", "cal.csv", "2026-11-21T00:00:00Z");
  pof::core::DynamicModel m;
  m.degree = 3;
  m.poly = {2.35, -0.99, 0.03, 0.02, 0, 0};
  m.n_operators = 2;
  m.threshold_deg = {1.0, 8.0};
  m.weight_v_per_deg = {0.004, 0.001};
  m.rate_gain_s_per_rad = -1.5;
  m.n_prony = 1;
  m.prony_tau_s = {5.0};
  m.prony_gain_v_per_deg = {-0.0004};
  m.bend_lag_s = 0.07;
  m.lag_window_s = 0.15;
  f.cal.dynamic = m;
  f.cal.active = pof::core::ModelKind::kDynamic;
  f.held_out = pof::io::HeldOutSummary{0.9, 2.8, 0.2, 0.6, 5};
  return f;
}


}  // namespace

TEST(CalibrationFile, DynamicModelRoundTripsExactlyAndEveryKeyIsNamed) {
  const auto f = with_dynamic_model();
  const std::string text = pof::io::to_toml(f);
  const auto g = pof::io::parse_calibration(text, "mem.toml");
  ASSERT_TRUE(g.cal.dynamic);
  EXPECT_EQ(g.cal.active, pof::core::ModelKind::kDynamic);
  EXPECT_EQ(g.cal.dynamic->poly, f.cal.dynamic->poly);
  EXPECT_EQ(g.cal.dynamic->threshold_deg, f.cal.dynamic->threshold_deg);
  EXPECT_EQ(g.cal.dynamic->weight_v_per_deg, f.cal.dynamic->weight_v_per_deg);
  EXPECT_EQ(g.cal.dynamic->prony_gain_v_per_deg, f.cal.dynamic->prony_gain_v_per_deg);
  EXPECT_EQ(g.cal.dynamic->rate_gain_s_per_rad, -1.5);
  EXPECT_EQ(g.cal.dynamic->bend_lag_s, 0.07);
  EXPECT_EQ(g.cal.dynamic->lag_window_s, 0.15);
  ASSERT_TRUE(g.held_out);
  EXPECT_EQ(g.held_out->dynamic_rmse_deg, 0.2);
  // Every key of [dynamic] and [held_out] is required once the section is there, except the bend
  // lag's two, which files written before it lack: absent, the fibre has no lag.
  std::istringstream in(text);
  std::string table;
  int checked = 0;
  for (std::string l; std::getline(in, l);) {
    if (!l.empty() && l[0] == '[') {
      table = l.substr(1, l.find(']') - 1);
      continue;
    }
    const auto eq = l.find(" = ");
    if ((table != "dynamic" && table != "held_out") || eq == std::string::npos) continue;
    const std::string key = table + "." + l.substr(0, eq);
    if (key == "dynamic.bend_lag_s" || key == "dynamic.lag_window_s") {
      const auto h = pof::io::parse_calibration(replace_line(text, l, ""), "cal.toml");
      EXPECT_EQ(key == "dynamic.bend_lag_s" ? h.cal.dynamic->bend_lag_s : h.cal.dynamic->lag_window_s,
                key == "dynamic.bend_lag_s" ? 0.0 : pof::core::DynamicModel{}.lag_window_s);
      continue;
    }
    const std::string e = error_of([&] { pof::io::parse_calibration(replace_line(text, l, ""), "cal.toml"); });
    EXPECT_NE(e.find("key '" + key + "'"), std::string::npos) << e;
    ++checked;
  }
  EXPECT_GE(checked, 17);
}

TEST(CalibrationFile, DamagedDynamicSectionsAreRefusedNamingTheKey) {
  const std::string text = pof::io::to_toml(with_dynamic_model());
  auto err = [&](const std::string& start, const std::string& repl) {
    return error_of([&] { pof::io::parse_calibration(replace_line(text, start, repl), "cal.toml"); });
  };
  EXPECT_NE(err("weights_v_per_deg", "weights_v_per_deg = [0.004, -0.001]").find("key 'dynamic': operator weights must share one sign"), std::string::npos);
  EXPECT_NE(err("poly = ", "poly = [1.0, 2.0]").find("key 'dynamic.poly': expected degree + 1 = 4"), std::string::npos);
  EXPECT_NE(err("thresholds_deg", "thresholds_deg = [1.0, -8.0]").find("key 'dynamic.thresholds_deg[1]'"), std::string::npos);
  EXPECT_NE(err("prony_tau_s", "prony_tau_s = [5.0, 9.0]").find("key 'dynamic.prony_gain_v_per_deg'"), std::string::npos);
  EXPECT_NE(err("degree", "degree = 9").find("key 'dynamic.degree'"), std::string::npos);
  EXPECT_NE(err("bend_lag_s", "bend_lag_s = -0.1").find("key 'dynamic': bend_lag_s must be within 0..2 s"), std::string::npos);
  EXPECT_NE(err("lag_window_s", "lag_window_s = 0").find("key 'dynamic.lag_window_s': expected a number > 0"), std::string::npos);
  EXPECT_NE(err("poly = ", "poly = \"x\"").find("key 'dynamic.poly': expected an array"), std::string::npos);
  EXPECT_NE(err("active_model", "active_model = \"lstm\"").find("key 'active_model'"), std::string::npos);
  // "dynamic" active with the section gone.
  std::string no_section;
  {
    std::istringstream in(text);
    bool skip = false;
    for (std::string l; std::getline(in, l);) {
      if (!l.empty() && l[0] == '[') skip = l.rfind("[dynamic]", 0) == 0;
      if (!skip) no_section += l + "\n";
    }
  }
  EXPECT_NE(error_of([&] { pof::io::parse_calibration(no_section, "cal.toml"); }).find("key 'active_model': is \"dynamic\" but the file has no [dynamic]"),
            std::string::npos);
  // --model dynamic on a file without one is a configuration error naming the file.
  auto paper_only = pof::io::parse_calibration(pof::io::to_toml(pof::io::make_calibration_file(fitted(), "S", "c.csv", "d")), "c.toml");
  EXPECT_THROW(pof::io::choose_model(paper_only, "dynamic", "c.toml"), ConfigError);
}

TEST(CalibrationFile, Version1FilesLoadWithThePaperModelAndCompensateBitIdentically) {
  auto f = pof::io::make_calibration_file(fitted(), "S", "cal.csv", "2026-11-21T00:00:00Z");
  std::string v1 = replace_line(pof::io::to_toml(f), "schema_version", "schema_version = 1");
  v1 = replace_line(v1, "active_model", "");
  const auto g = pof::io::parse_calibration(v1, "old.toml");
  EXPECT_EQ(g.cal.active, pof::core::ModelKind::kPaper);
  EXPECT_FALSE(g.cal.dynamic);
  const auto rec = pof::testing::paper_recording();
  const auto a = pof::core::compensate_recording(rec.t_s, rec.sensor_v, rec.reference_v, rec.angle_ref_deg, fitted().cal);
  const auto b = pof::core::compensate_recording(rec.t_s, rec.sensor_v, rec.reference_v, rec.angle_ref_deg, g.cal);
  ASSERT_EQ(a.angle_deg.size(), b.angle_deg.size());
  for (Eigen::Index i = 0; i < a.angle_deg.size(); ++i) {
    if (!(std::isnan(a.angle_deg(i)) && std::isnan(b.angle_deg(i)))) {
      ASSERT_EQ(a.angle_deg(i), b.angle_deg(i)) << i;
    }
  }
}

namespace {

// `text` with `line` inserted after the first line that starts with `after`; `at` is set to the
// inserted line's number (1-based), as the reader's messages count.
std::string insert_after(const std::string& text, const std::string& after, const std::string& line, int& at) {
  std::istringstream in(text);
  std::string out;
  int n = 0;
  at = 0;
  for (std::string l; std::getline(in, l);) {
    out += l + "\n";
    ++n;
    if (at == 0 && l.rfind(after, 0) == 0) {
      out += line + "\n";
      at = ++n;
    }
  }
  return out;
}

}  // namespace

// Every section refuses a key it does not read, at its line, with the nearest known key: a typo
// must not leave the model on a default (docs/calibration.md).
TEST(CalibrationFile, UnknownKeysAreRefusedAtTheirLineWithASuggestion) {
  auto f = with_dynamic_model();
  f.potentiometer = pof::core::PotentiometerCalibration{18.0, 0.1, {{0, 0.5}, {90, -0.5}}};
  const std::string text = pof::io::to_toml(f);
  ASSERT_EQ(error_of([&] { pof::io::parse_calibration(text, "cal.toml"); }), "(no error)");
  auto unknown = [&](const std::string& after, const std::string& line) {
    int at = 0;
    const std::string bad = insert_after(text, after, line, at);
    EXPECT_GT(at, 0) << after;
    return std::make_pair(error_of([&] { pof::io::parse_calibration(bad, "cal.toml"); }), at);
  };
  auto [e, at] = unknown("c10 = ", "c9x = 1.0");
  EXPECT_EQ(e, "cal.toml:" + std::to_string(at) + ": unknown key 'c9x' in [model] (did you mean 'c9'?)");
  std::tie(e, at) = unknown("prony_tau_s", "prony_tau = [1.0]");
  EXPECT_EQ(e, "cal.toml:" + std::to_string(at) + ": unknown key 'prony_tau' in [dynamic] (did you mean 'prony_tau_s'?)");
  std::tie(e, at) = unknown("zero_v", "zero = 0.1");
  EXPECT_EQ(e, "cal.toml:" + std::to_string(at) + ": unknown key 'zero' in [potentiometer] (did you mean 'zero_v'?)");
  std::tie(e, at) = unknown("sensor_id", "sensor = \"L\"");
  EXPECT_EQ(e, "cal.toml:" + std::to_string(at) + ": unknown key 'sensor' at the top level (did you mean 'sensor_id'?)");
  std::tie(e, at) = unknown("c8 = ", "c88 = 1.0");
  EXPECT_EQ(e, "cal.toml:" + std::to_string(at) + ": unknown key 'c88' in [model.flexion] (did you mean 'c8'?)");
  std::tie(e, at) = unknown("folds", "fold = 5");
  EXPECT_EQ(e, "cal.toml:" + std::to_string(at) + ": unknown key 'fold' in [held_out] (did you mean 'folds'?)");
  // Value errors carry the line too.
  std::tie(e, at) = unknown("c10 = ", "c1 = -2.0");  // a second c1: a TOML error, at its line
  EXPECT_EQ(e.rfind("cal.toml:" + std::to_string(at) + ": TOML syntax error", 0), 0u) << e;
  const std::string neg = replace_line(text, "c1 = ", "c1 = -2.0");
  const auto c1_at = neg.find("\nc1 = ");
  const long c1_line = std::count(neg.begin(), neg.begin() + static_cast<std::ptrdiff_t>(c1_at) + 1, '\n') + 1;
  EXPECT_EQ(error_of([&] { pof::io::parse_calibration(neg, "cal.toml"); }).rfind("cal.toml:" + std::to_string(c1_line) + ": key 'model.c1': expected a number > 0, got -2", 0), 0u);
}

// Schema_version 2 keys in a version 1 file are refused, not ignored.
TEST(CalibrationFile, Version2KeysNeedVersion2) {
  const std::string v2 = pof::io::to_toml(pof::io::make_calibration_file(fitted(), "S", "cal.csv", "2026-11-21T00:00:00Z"));
  std::string v1 = replace_line(replace_line(v2, "schema_version", "schema_version = 1"), "active_model", "");
  EXPECT_NE(error_of([&] { pof::io::parse_calibration(replace_line(v1, "schema_version", "schema_version = 1\nactive_model = \"paper\""), "old.toml"); })
                .find("key 'active_model': is a schema_version 2 key, but the file says schema_version = 1"),
            std::string::npos);
}

namespace {

// A [gap] section as `pof gap` writes it (docs/calibration.md, "`[gap]`: effect terms and how the
// compensator applies them"), written here by hand.
const char* const kGapSection = R"([gap]
schema_version = 1
delay_s = 0.012
backlash_deg = 0.6
[[gap.terms]]
effect = "creep"
theta = 5.0
coefficients_v = [ -0.0012 ]
[gap.terms.parameters]
tau_s = 5.0
gain_deg_per_deg = 0.055
[[gap.terms]]
effect = "memory_hysteresis"
coefficients_v = [ 0.0003, 0.0002 ]
thresholds_deg = [ 1.0, 4.0 ]
[[gap.terms]]
effect = "viscoelastic_relaxation"
theta = 0
coefficients_v = [ -0.0005, -0.0002 ]
time_constants_s = [ 1.5, 30 ]
[[gap.terms]]
effect = "periodic_interference"
theta = 50.0
coefficients_v = [ 0.001, 0.002, 0.0, 0.0005 ]
[[gap.terms]]
effect = "memory_hysteresis"
theta = 12.0
coefficients_v = [ 0.0001, 0.0004, 0.0002 ]
relay_centres_deg = [ 20.0, 35.0, 50.0 ]
)";

std::string with_gap(const std::string& gap_section) {
  return pof::io::to_toml(pof::io::make_calibration_file(fitted(), "S", "cal.csv", "2026-11-21T00:00:00Z")) + "\n" + gap_section;
}

// The line (1-based) of the first line of `text` that starts with `start` at or after line `from`.
int line_of(const std::string& text, const std::string& start, int from = 1) {
  std::istringstream in(text);
  int n = 0;
  for (std::string l; std::getline(in, l);)
    if (++n >= from && l.rfind(start, 0) == 0) return n;
  return 0;
}

}  // namespace

TEST(CalibrationFile, GapTermsAreReadWrittenBackAndApplied) {
  TempDir d;
  const std::string text = with_gap(kGapSection);
  const auto f = pof::io::parse_calibration(text, "model.toml");
  ASSERT_TRUE(f.cal.gap);
  const pof::core::GapModel& g = *f.cal.gap;
  EXPECT_EQ(g.delay_s, 0.012);
  EXPECT_EQ(g.backlash_deg, 0.6);
  ASSERT_EQ(g.terms.size(), 5u);
  EXPECT_EQ(g.terms[0].effect, "creep");
  EXPECT_EQ(g.terms[0].theta, 5.0);
  EXPECT_EQ(g.terms[0].coefficients_v, std::vector<double>{-0.0012});
  EXPECT_EQ(g.terms[0].parameters, (std::vector<std::pair<std::string, double>>{{"tau_s", 5.0}, {"gain_deg_per_deg", 0.055}}));
  EXPECT_EQ(g.terms[0].line, line_of(text, "[[gap.terms]]"));
  EXPECT_EQ(g.terms[1].theta, 0.0);  // absent: 0
  EXPECT_EQ(g.terms[1].thresholds_deg, (std::vector<double>{1.0, 4.0}));
  EXPECT_EQ(g.terms[2].time_constants_s, (std::vector<double>{1.5, 30.0}));
  EXPECT_EQ(g.terms[3].coefficients_v.size(), 4u);
  EXPECT_EQ(g.terms[4].theta, 12.0);  // the relay form
  EXPECT_EQ(g.terms[4].relay_centres_deg, (std::vector<double>{20.0, 35.0, 50.0}));
  // Written back by io's one writer and read again: the same model, the same text.
  const std::string once = pof::io::to_toml(f);
  const auto again = pof::io::parse_calibration(once, "again.toml");
  ASSERT_TRUE(again.cal.gap);
  for (std::size_t i = 0; i < g.terms.size(); ++i) {
    const auto &a = g.terms[i], &b = again.cal.gap->terms[i];
    EXPECT_EQ(a.effect, b.effect);
    EXPECT_EQ(a.theta, b.theta);
    EXPECT_EQ(a.coefficients_v, b.coefficients_v);
    EXPECT_EQ(a.thresholds_deg, b.thresholds_deg);
    EXPECT_EQ(a.relay_centres_deg, b.relay_centres_deg);
    EXPECT_EQ(a.time_constants_s, b.time_constants_s);
    EXPECT_EQ(a.parameters, b.parameters);
  }
  EXPECT_EQ(again.cal.gap->delay_s, g.delay_s);
  EXPECT_EQ(again.cal.gap->backlash_deg, g.backlash_deg);
  EXPECT_EQ(pof::io::to_toml(again), once);
  // A name that is no bare key is quoted.
  auto odd = f;
  odd.cal.gap->terms[0].parameters.emplace_back("tau (s)", 1.0);
  EXPECT_EQ(pof::io::parse_calibration(pof::io::to_toml(odd), "odd.toml").cal.gap->terms[0].parameters.back().first, "tau (s)");
  // What the compensator's programs load applies it: the angle moves.
  const auto loaded = pof::io::load_calibration(d.file("model.toml", text), "file", 200.0);
  const auto rec = pof::testing::paper_recording();
  const auto plain = pof::core::compensate_recording(rec.t_s, rec.sensor_v, rec.reference_v, rec.angle_ref_deg, fitted().cal);
  const auto gap = pof::core::compensate_recording(rec.t_s, rec.sensor_v, rec.reference_v, rec.angle_ref_deg, loaded.cal);
  EXPECT_GT((plain.angle_deg - gap.angle_deg).cwiseAbs().maxCoeff(), 0.1);
}

// Every term the compensator cannot apply is refused by what pof compensate and pof-compensatord
// load, each on its own line with the file, its line, number, effect and why; the parser alone
// still reads such a file (`pof gap` writes what it found and checks it reads back).
TEST(CalibrationFile, GapTermsTheCompensatorCannotApplyAreRefusedAtLoad) {
  TempDir d;
  auto refused = [&](const std::string& name, const std::string& gap_section, double rate = 0) {
    const std::string text = with_gap(gap_section);
    EXPECT_NO_THROW(pof::io::parse_calibration(text, name));
    const std::string path = d.file(name, text);
    std::string e;
    try {
      (void)pof::io::load_calibration(path, "file", rate);
      e = "(no error)";
    } catch (const pof::ConfigError& x) {
      EXPECT_EQ(x.code(), 78);
      e = x.what();
    }
    return std::make_pair(e, path);
  };
  const std::string head = "[gap]\nschema_version = 1\n";
  const std::string creep = "[[gap.terms]]\neffect = \"creep\"\ntheta = 5.0\ncoefficients_v = [-0.001]\n";
  auto [e, path] = refused("drift.toml", head + creep + "[[gap.terms]]\neffect = \"drift\"\ncoefficients_v = [0.002]\n");
  const int drift_line = line_of(with_gap(head + creep), "[[gap.terms]]") + 4;
  EXPECT_EQ(e, path + ":" + std::to_string(drift_line) +
                   ": [gap] term 2 'drift': a trend over the calibration recording cannot be applied online; remove it or recalibrate");
  std::tie(e, path) = refused("unknown.toml", head + "[[gap.terms]]\neffect = \"mains\"\ntheta = 50.0\ncoefficients_v = [1.0]\n");
  EXPECT_NE(e.find("[gap] term 1 'mains': not an effect of the catalogue (docs/gap.md): expected one of 'static_nonlinearity', "), std::string::npos) << e;
  std::tie(e, path) = refused("count.toml", head + "[[gap.terms]]\neffect = \"static_nonlinearity\"\ncoefficients_v = [1.0, 2.0]\n");
  EXPECT_NE(e.find("[gap] term 1 'static_nonlinearity': expected 4 coefficients_v (one per basis function), got 2"), std::string::npos) << e;
  std::tie(e, path) = refused("thresholds.toml", head + "[[gap.terms]]\neffect = \"memory_hysteresis\"\ncoefficients_v = [1.0]\nthresholds_deg = [0.0]\n");
  EXPECT_NE(e.find("[gap] term 1 'memory_hysteresis': thresholds_deg must be finite and > 0, got 0"), std::string::npos) << e;
  std::tie(e, path) = refused("tau.toml", head + "[[gap.terms]]\neffect = \"viscoelastic_relaxation\"\ncoefficients_v = [1.0]\ntime_constants_s = [-2.0]\n");
  EXPECT_NE(e.find("[gap] term 1 'viscoelastic_relaxation': time_constants_s must be finite and > 0, got -2"), std::string::npos) << e;
  std::tie(e, path) = refused("delay.toml", "[gap]\nschema_version = 1\ndelay_s = 3.0\n");
  EXPECT_EQ(e, path + ": [gap] delay_s: expected a finite delay within +-1 s, got 3");
  // Two at once: both named, one line each.
  std::tie(e, path) = refused("two.toml", head + "[[gap.terms]]\neffect = \"drift\"\ncoefficients_v = [0.002]\n" + creep +
                                              "[[gap.terms]]\neffect = \"backlash\"\ncoefficients_v = []\n");
  EXPECT_NE(e.find("[gap] term 1 'drift'"), std::string::npos) << e;
  EXPECT_NE(e.find("\n" + path + ":"), std::string::npos) << e;
  EXPECT_NE(e.find("[gap] term 3 'backlash': a kinematic effect, given as [gap] backlash_deg, not as a term"), std::string::npos) << e;
  // A notch at or above Nyquist: refused at the rate it would run at, not without one.
  const std::string notch = head + "[[gap.terms]]\neffect = \"periodic_interference\"\ntheta = 120.0\ncoefficients_v = [1.0, 0.0, 0.0, 0.0]\n";
  EXPECT_EQ(refused("notch.toml", notch).first, "(no error)");
  std::tie(e, path) = refused("notch.toml", notch, 200.0);
  EXPECT_NE(e.find("[gap] term 1 'periodic_interference': the frequency 120 Hz is at or above the Nyquist frequency 100 Hz of 200 Hz scans"), std::string::npos) << e;
  EXPECT_EQ(refused("notch.toml", notch, 1000.0).first, "(no error)");
}

// [gap] is read as strictly as the rest: types, finite numbers, unknown keys, its own version.
TEST(CalibrationFile, GapSectionErrorsNameTheFileLineAndKey) {
  auto error = [](const std::string& gap_section) {
    return error_of([&] { pof::io::parse_calibration(with_gap(gap_section), "model.toml"); });
  };
  auto at = [](const std::string& gap_section, const std::string& start) {
    return "model.toml:" + std::to_string(line_of(with_gap(gap_section), start, line_of(with_gap(gap_section), "[gap]"))) + ": ";
  };
  std::string g = "[gap]\nschema_version = 1\n[[gap.terms]]\neffect = \"creep\"\ntheta = 5.0\ncoeficients_v = [-0.001]\n";
  EXPECT_EQ(error(g), at(g, "[[gap.terms]]") + "key 'gap.terms[0].coefficients_v': missing");
  g = "[gap]\nschema_version = 1\n[[gap.terms]]\neffect = \"creep\"\ntheta = 5.0\ncoefficients_v = [-0.001]\ncoeficients_v = [-0.001]\n";
  EXPECT_EQ(error(g), at(g, "coeficients_v") + "unknown key 'coeficients_v' in gap.terms[0] (did you mean 'coefficients_v'?)");
  g = "[gap]\nschema_version = 1\nkappa = 1.02\n";
  EXPECT_EQ(error(g), at(g, "kappa") + "unknown key 'kappa' in [gap]");
  g = "[gap]\ndelay_s = 0.01\n";
  EXPECT_EQ(error(g), at(g, "[gap]") + "key 'gap.schema_version': missing (this program reads schema_version 1)");
  g = "[gap]\nschema_version = 2\n";
  EXPECT_EQ(error(g), at(g, "schema_version") + "key 'gap.schema_version': expected 1, got 2");
  g = "[gap]\nschema_version = 1\n[[gap.terms]]\neffect = \"creep\"\ntheta = nan\ncoefficients_v = [-0.001]\n";
  EXPECT_EQ(error(g), at(g, "theta") + "key 'gap.terms[0].theta': expected a finite number, got nan");
  g = "[gap]\nschema_version = 1\n[[gap.terms]]\neffect = \"creep\"\ntheta = 5.0\ncoefficients_v = [-0.001, inf]\n";
  EXPECT_EQ(error(g), at(g, "coefficients_v") + "key 'gap.terms[0].coefficients_v[1]': expected a finite number, got inf");
  g = "[gap]\nschema_version = 1\n[[gap.terms]]\neffect = \"creep\"\ntheta = 5.0\ncoefficients_v = [-0.001]\n[gap.terms.parameters]\ntau_s = \"five\"\n";
  EXPECT_EQ(error(g), at(g, "tau_s") + "key 'gap.terms[0].parameters.tau_s': expected a number, got a string 'five'");
  g = "[gap]\nschema_version = 1\n[[gap.terms]]\ntheta = 5.0\ncoefficients_v = [-0.001]\n";
  EXPECT_EQ(error(g), at(g, "[[gap.terms]]") + "key 'gap.terms[0].effect': missing");
}

TEST(PotentiometerFile, ReadsItsSectionStrictlyAlsoFromACalibrationFile) {
  TempDir d;
  const auto own = d.file("pot.toml", "schema_version = 1\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\n");
  EXPECT_EQ(pof::io::load_potentiometer(own).deg_per_volt, 22.5);
  EXPECT_EQ(pof::io::load_potentiometer(d.file("bare.toml", "[potentiometer]\ndeg_per_volt = 18.0\nzero_v = 0.0\n")).deg_per_volt, 18.0);
  // A whole calibration file (every section of it) serves as --pot-cal.
  auto f = with_dynamic_model();
  f.potentiometer = pof::core::PotentiometerCalibration{18.0, 0.1, {{0, 0.5}, {90, -0.5}}};
  EXPECT_EQ(pof::io::load_potentiometer(d.file("cal.toml", pof::io::to_toml(f))).offsets.size(), 2u);
  const auto typo = d.file("typo.toml", "schema_version = 1\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\nzero_volts = 3\n");
  EXPECT_EQ(error_of([&] { pof::io::load_potentiometer(typo); }), typo + ":5: unknown key 'zero_volts' in [potentiometer] (did you mean 'zero_v'?)");
  const auto misnamed = d.file("misnamed.toml", "[potentiometr]\ndeg_per_volt = 22.5\nzero_v = 0.5\n");
  EXPECT_EQ(error_of([&] { pof::io::load_potentiometer(misnamed); }),
            misnamed + ":1: unknown key 'potentiometr' at the top level (did you mean 'potentiometer'?)");
  const auto stray = d.file("stray.toml", "zero_v = 0.5\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\n");
  EXPECT_EQ(error_of([&] { pof::io::load_potentiometer(stray); }), stray + ":1: unknown key 'zero_v' at the top level");
  const auto version = d.file("v9.toml", "schema_version = 9\n[potentiometer]\ndeg_per_volt = 22.5\nzero_v = 0.5\n");
  EXPECT_EQ(error_of([&] { pof::io::load_potentiometer(version); }), version + ":1: key 'schema_version': expected 1, 2 or 3, got 9");
}

// An output that is a device or a pipe is written into, never renamed over: as root a rename
// replaced /dev/null with a regular file. A FIFO (any user may make one) stays a FIFO and its
// reader gets the bytes; a directory is refused by name.
TEST(AtomicWrite, APipeOrDeviceIsWrittenInPlace) {
  TempDir d;
  const std::string fifo = d.path("pipe");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0) << std::strerror(errno);
  // The reader's end is open first (non-blocking), so neither side waits; the text fits the pipe.
  const int rd = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  ASSERT_GE(rd, 0) << std::strerror(errno);
  pof::io::write_file_atomic(fifo, "t_s,angle_deg\n0,1\n");
  char buf[64] = {};
  const ssize_t n = ::read(rd, buf, sizeof buf);
  ::close(rd);
  EXPECT_EQ(std::string(buf, n > 0 ? static_cast<std::size_t>(n) : 0), "t_s,angle_deg\n0,1\n");
  EXPECT_TRUE(fs::is_fifo(fifo));
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(d.path())) ++entries;
  EXPECT_EQ(entries, 1) << "no temporary file beside the pipe";
  EXPECT_NO_THROW(pof::io::write_file_atomic("/dev/null", "x"));
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  try {
    pof::io::write_file_atomic(d.path(), "x");
    ADD_FAILURE() << "a directory was written";
  } catch (const pof::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("is a directory"), std::string::npos) << e.what();
  }
}

TEST(AtomicWrite, ReplacesWholeFilesAndLeavesNothingOnFailure) {
  TempDir d;
  const auto p = d.file("out.txt", "old");
  pof::io::write_file_atomic(p, "new content");
  std::ifstream in(p);
  std::string s;
  std::getline(in, s);
  EXPECT_EQ(s, "new content");
  EXPECT_THROW(pof::io::write_file_atomic(d.path("no_dir/out.txt"), "x"), pof::IoError);
  int files = 0;
  for (const auto& e : fs::directory_iterator(fs::path(p).parent_path())) files += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(files, 1) << "no temporary file left behind";
}

// [estimator] (schema 3): round trip, each key named when damaged, refused in an older schema and
// without the [dynamic] section it estimates for; a schema 2 file without it still loads.
TEST(CalibrationFile, EstimatorSectionRoundTripsAndDamageIsNamed) {
  auto f = with_dynamic_model();
  f.cal.estimator = pof::core::EstimatorNoise{0.0016, 300};
  const std::string text = pof::io::to_toml(f);
  const auto g = pof::io::parse_calibration(text, "mem.toml");
  ASSERT_TRUE(g.cal.estimator);
  EXPECT_EQ(g.cal.estimator->voltage_noise_v, 0.0016);
  EXPECT_EQ(g.cal.estimator->acceleration_noise_deg_s2, 300);
  auto err = [&](const std::string& from, const std::string& start, const std::string& repl) {
    return error_of([&] { pof::io::parse_calibration(replace_line(from, start, repl), "cal.toml"); });
  };
  EXPECT_NE(err(text, "voltage_noise_v", "voltage_noise_v = -0.001").find("key 'estimator.voltage_noise_v': expected a number > 0"),
            std::string::npos);
  EXPECT_NE(err(text, "acceleration_noise_deg_s2", "").find("key 'estimator.acceleration_noise_deg_s2'"), std::string::npos);
  EXPECT_NE(err(text, "acceleration_noise_deg_s2", "acceleration_noise_deg_s2 = nan").find("key 'estimator.acceleration_noise_deg_s2'"),
            std::string::npos);
  EXPECT_NE(err(text, "schema_version", "schema_version = 2").find("key 'estimator': is a schema_version 3 section"), std::string::npos);
  const std::string v2 = replace_line(replace_line(replace_line(replace_line(text, "[estimator]", ""), "voltage_noise_v", ""),
                                                   "acceleration_noise_deg_s2", ""),
                                      "schema_version", "schema_version = 2");
  const auto old = pof::io::parse_calibration(v2, "old.toml");
  EXPECT_FALSE(old.cal.estimator);
  ASSERT_TRUE(old.cal.dynamic);
  auto no_dynamic = f;
  no_dynamic.cal.dynamic.reset();
  no_dynamic.cal.active = pof::core::ModelKind::kPaper;
  EXPECT_NE(error_of([&] { pof::io::parse_calibration(pof::io::to_toml(no_dynamic), "cal.toml"); })
                .find("key 'estimator': needs a [dynamic] section"),
            std::string::npos);
}
