// The strict TOML reader every pofkit file goes through (common/base/include/pof/base/toml_reader.hpp):
// typed values with file:line, ranges, unknown keys with a suggestion, schema_version.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "pof/base/errors.hpp"
#include "pof/base/exit_codes.hpp"
#include "pof/base/format.hpp"
#include "pof/base/text_file.hpp"
#include "pof/base/toml_reader.hpp"
#include "temp_dir.hpp"

namespace {

using pof::TomlSection;
namespace check = pof::toml_check;

// The ConfigError `read` throws (exit 78), or "(no error)".
std::string error_of(const std::function<void()>& read) {
  try {
    read();
  } catch (const pof::ConfigError& e) {
    EXPECT_EQ(e.code(), pof::kExitConfig);
    return e.what();
  } catch (const std::exception& e) {
    return std::string("other exception: ") + e.what();
  }
  return "(no error)";
}

// Reads `text` as f.toml with `read(root)`, then finishes the root.
std::string error_reading(const std::string& text, const std::function<void(TomlSection&)>& read) {
  return error_of([&] {
    const toml::table t = pof::parse_toml(text, "f.toml");
    TomlSection root(t, "f.toml");
    read(root);
    root.finish();
  });
}

TEST(TomlReader, CommandLineValuesAreSetAsGivenAndOverridesParsed) {
  toml::table t = pof::parse_toml("[lcm]\nurl = \"udpm://a\"\n", "daq.toml");
  // An option's text is a value as it is: quotes and backslashes are not TOML syntax here.
  pof::set_toml_path(t, "lcm.sensor_id", std::string("KNEE \"L\" \\1"));
  pof::set_toml_path(t, "acquisition.decimate", std::int64_t{5});
  EXPECT_EQ(t["lcm"]["sensor_id"].value<std::string>(), "KNEE \"L\" \\1");
  EXPECT_EQ(t["acquisition"]["decimate"].value<std::int64_t>(), 5);
  pof::apply_toml_override(t, "acquisition.range_v=2.5");
  pof::apply_toml_override(t, "device.kind=sim:paper");  // a bare word: a string
  EXPECT_EQ(t["acquisition"]["range_v"].value<double>(), 2.5);
  EXPECT_EQ(t["device"]["kind"].value<std::string>(), "sim:paper");
  EXPECT_EQ(error_of([&] { pof::apply_toml_override(t, "lcm.url.port=1"); }),
            "command line: override 'lcm.url.port=1': 'url' is not a table");
  EXPECT_EQ(error_of([&] { pof::apply_toml_override(t, "=1"); }), "command line: override '=1': expected key.path=value");
}

}  // namespace

TEST(TomlReader, ValuesAreReadTypedAndChecked) {
  const toml::table t = pof::parse_toml("a = 2\nb = 2.5\nc = true\nd = 'x'\n[s]\nn = 7\n", "f.toml");
  TomlSection root(t, "f.toml");
  EXPECT_EQ(root.get<double>("a"), 2.0);  // a TOML integer is a number
  EXPECT_EQ(root.get<double>("b", check::positive()), 2.5);
  EXPECT_TRUE(root.get<bool>("c"));
  EXPECT_EQ(root.get<std::string>("d"), "x");
  EXPECT_EQ(root.get_or("absent", 4.5, check::positive()), 4.5);
  EXPECT_EQ(root.get_or("absent_too", -1, check::integer_in(0, 3)), -1);  // the check is on the file's value
  EXPECT_FALSE(root.find<int>("nothing"));
  EXPECT_TRUE(root.with_section("s", [](TomlSection& s) { EXPECT_EQ(s.get<int>("n", check::integer_in(1, 10)), 7); }));
  EXPECT_FALSE(root.with_section("no_such_section", [](TomlSection&) { ADD_FAILURE(); }));
  EXPECT_NO_THROW(root.finish());
}

TEST(TomlReader, TypeErrorsNameFileLineKeyAndTheValue) {
  const std::string text = "schema_version = 1\n\n[acquisition]\nrate = 'fast'\ncount = 2.0\nflag = 1\nname = [1]\nbig = 3000000000\nx = nan\n";
  auto err = [&](const std::function<void(TomlSection&)>& read) {
    return error_reading(text, [&](TomlSection& root) {
      TomlSection a = root.section("acquisition");
      read(a);
    });
  };
  EXPECT_EQ(err([](TomlSection& a) { (void)a.get<double>("rate"); }),
            "f.toml:4: key 'acquisition.rate': expected a number, got a string 'fast'");
  EXPECT_EQ(err([](TomlSection& a) { (void)a.get<int>("count"); }), "f.toml:5: key 'acquisition.count': expected an integer, got 2.0");
  EXPECT_EQ(err([](TomlSection& a) { (void)a.get<bool>("flag"); }), "f.toml:6: key 'acquisition.flag': expected true or false, got 1");
  EXPECT_EQ(err([](TomlSection& a) { (void)a.get<std::string>("name"); }), "f.toml:7: key 'acquisition.name': expected a string, got an array");
  EXPECT_EQ(err([](TomlSection& a) { (void)a.get<int>("big"); }),
            "f.toml:8: key 'acquisition.big': expected an integer in [-2147483648, 2147483647], got 3000000000");
  EXPECT_EQ(err([](TomlSection& a) { (void)a.get<double>("x"); }), "f.toml:9: key 'acquisition.x': expected a finite number, got nan");
  EXPECT_EQ(err([](TomlSection& a) { (void)a.section("rate"); }), "f.toml:4: key 'acquisition.rate': expected a table, got a string 'fast'");
  EXPECT_EQ(err([](TomlSection& a) { (void)a.array("count"); }), "f.toml:5: key 'acquisition.count': expected an array, got 2.0");
  // Missing: at the line of the section's header; at the top level there is no line to name.
  EXPECT_EQ(err([](TomlSection& a) { (void)a.get<double>("scan_rate_hz"); }), "f.toml:3: key 'acquisition.scan_rate_hz': missing");
  EXPECT_EQ(error_reading(text, [](TomlSection& r) { (void)r.get<std::string>("sensor_id"); }), "f.toml: key 'sensor_id': missing");
}

TEST(TomlReader, RangesAndRulesSayWhatWasExpected) {
  const std::string text = "[q]\nrate = 20000\ndecimate = 0\nc9 = -3\nterminal = 'diff'\nv = 0.5\n";
  auto err = [&](const std::function<void(TomlSection&)>& read) {
    return error_reading(text, [&](TomlSection& root) {
      TomlSection q = root.section("q");
      read(q);
    });
  };
  EXPECT_EQ(err([](TomlSection& q) { (void)q.get<double>("rate", check::number_in(1, 10000)); }),
            "f.toml:2: key 'q.rate': expected a number in [1, 10000], got 20000");
  EXPECT_EQ(err([](TomlSection& q) { (void)q.get<int>("decimate", check::integer_in(1, 10000)); }),
            "f.toml:3: key 'q.decimate': expected an integer in [1, 10000], got 0");
  EXPECT_EQ(err([](TomlSection& q) { (void)q.get<double>("c9", check::positive()); }), "f.toml:4: key 'q.c9': expected a number > 0, got -3");
  EXPECT_EQ(err([](TomlSection& q) {
              (void)q.get<double>("v", [](double v) { return v > 1 ? std::string{} : std::string("a gain above 1"); });
            }),
            "f.toml:6: key 'q.v': expected a gain above 1, got 0.5");
  enum class T { kRse, kDiff };
  EXPECT_EQ(err([](TomlSection& q) { (void)q.get_enum_or("terminal", T::kRse, {{"rse", T::kRse}, {"differential", T::kDiff}}); }),
            "f.toml:5: key 'q.terminal': expected one of 'rse', 'differential', got 'diff'");
  EXPECT_EQ(err([](TomlSection& q) { (void)q.get_enum<int>("mode", {{"scan", 0}, {"single", 1}}); }),
            "f.toml:1: key 'q.mode': missing (one of 'scan', 'single')");
  // A rule across keys names the key that has to change, at its line, also from the root.
  EXPECT_EQ(err([](TomlSection& q) { q.fail("decimate", "must divide rate"); }), "f.toml:3: key 'q.decimate': must divide rate");
  EXPECT_EQ(error_reading(text, [](TomlSection& r) { r.fail("q.c9", "too small"); }), "f.toml:4: key 'q.c9': too small");
}

TEST(TomlReader, UnknownKeysAreRefusedWithTheNearestKnownOne) {
  const std::string text = "schema_version = 1\n[quasi_static]\nc1 = 1\nc9x = 2\n";
  const std::string e = error_reading(text, [](TomlSection& root) {
    (void)root.schema_version({1});
    root.with_section("quasi_static", [](TomlSection& q) {
      for (const char* k : {"c1", "c2", "c9", "c10"}) (void)q.get_or(k, 0.0);
    });
  });
  EXPECT_EQ(e, "f.toml:4: unknown key 'c9x' in [quasi_static] (did you mean 'c9'?)");
  // Transposed letters, a missing unit suffix, another case: typos; a foreign word is not.
  auto unknown = [](const std::string& key, std::initializer_list<const char*> known) {
    return error_reading("[s]\n" + key + " = 1\n", [&](TomlSection& root) {
      root.with_section("s", [&](TomlSection& s) {
        for (const char* k : known) (void)s.get_or(k, 0.0);
      });
    });
  };
  EXPECT_EQ(unknown("widht_deg", {"width_deg", "shape"}), "f.toml:2: unknown key 'widht_deg' in [s] (did you mean 'width_deg'?)");
  EXPECT_EQ(unknown("scan_rate", {"scan_rate_hz", "decimate"}), "f.toml:2: unknown key 'scan_rate' in [s] (did you mean 'scan_rate_hz'?)");
  EXPECT_EQ(unknown("C9", {"c9"}), "f.toml:2: unknown key 'C9' in [s] (did you mean 'c9'?)");
  EXPECT_EQ(unknown("extra", {"device", "channels"}), "f.toml:2: unknown key 'extra' in [s]");
  // The first in the file is named; the top level says so; array elements by index.
  EXPECT_EQ(error_reading("zz = 1\naa = 2\n", [](TomlSection&) {}), "f.toml:1: unknown key 'zz' at the top level");
  EXPECT_EQ(error_reading("[[trajectory]]\nkind = 'hold'\n[[trajectory]]\nkind = 'hold'\nduraton_s = 1\n",
                          [](TomlSection& root) {
                            const pof::TomlArray a = root.array("trajectory");
                            for (std::size_t i = 0; i < a.size(); ++i) {
                              TomlSection s = a.section(i);
                              (void)s.get<std::string>("kind");
                              (void)s.get_or("duration_s", 0.0);
                              s.finish();
                            }
                          }),
            "f.toml:5: unknown key 'duraton_s' in trajectory[1] (did you mean 'duration_s'?)");
  // A section read and ignored on purpose is not unknown.
  EXPECT_EQ(error_reading("[gap]\nkappa = 1\n", [](TomlSection& root) { root.ignore("gap"); }), "(no error)");
  // A damaged file's key is quoted bounded.
  const std::string huge = "\"" + std::string(100000, 'k') + "\" = 1\n";
  const std::string h = error_reading(huge, [](TomlSection&) {});
  EXPECT_LT(h.size(), 200u) << h.substr(0, 200);
  EXPECT_NE(h.find("unknown key 'kkkk"), std::string::npos) << h.substr(0, 200);
}

// A free-form table (its keys are data): keys in file order, not toml++'s sorted order, each read
// like any key; the line a table of an array starts at.
TEST(TomlReader, FreeFormTablesListTheirKeysInFileOrder) {
  const toml::table t = pof::parse_toml("[[t]]\nx = 1\n[t.p]\nzeta = 1.5\nalpha = 2\n\n[[t]]\nx = 2\np = { b = 1, a = 'no' }\n", "f.toml");
  TomlSection root(t, "f.toml");
  const pof::TomlArray a = root.array("t");
  TomlSection first = a.section(0), second = a.section(1);
  EXPECT_EQ(root.line(), 0);
  EXPECT_EQ(first.line(), 1);
  EXPECT_EQ(second.line(), 7);
  TomlSection p = first.section("p");
  EXPECT_EQ(p.keys(), (std::vector<std::string>{"zeta", "alpha"}));
  for (const std::string& k : p.keys()) (void)p.get<double>(k);
  EXPECT_NO_THROW(p.finish());
  TomlSection q = second.section("p");
  EXPECT_EQ(q.keys(), (std::vector<std::string>{"b", "a"}));
  EXPECT_EQ(error_of([&] {
              for (const std::string& k : q.keys()) (void)q.get<double>(k);
            }),
            "f.toml:9: key 't[1].p.a': expected a number, got a string 'no'");
}

TEST(TomlReader, SchemaVersionIsCheckedOneWay) {
  auto version = [](const std::string& text, std::initializer_list<int> supported) {
    return error_reading(text, [&](TomlSection& root) { (void)root.schema_version(supported); });
  };
  EXPECT_EQ(version("schema_version = 2\n", {1, 2}), "(no error)");
  EXPECT_EQ(error_of([] {
              const toml::table t = pof::parse_toml("[[trajectory]]\n", "f.toml");
              (void)TomlSection(t, "f.toml").schema_version({1});
            }),
            "f.toml: key 'schema_version': missing (this program reads schema_version 1)");
  EXPECT_EQ(version("\nschema_version = 7\n", {1, 2}), "f.toml:2: key 'schema_version': expected 1 or 2, got 7");
  EXPECT_EQ(version("schema_version = '1'\n", {1, 2, 3}), "f.toml:1: key 'schema_version': expected an integer, got a string '1'");
  EXPECT_EQ(version("schema_version = 4\n", {1, 2, 3}), "f.toml:1: key 'schema_version': expected 1, 2 or 3, got 4");
}

TEST(TomlReader, ArraysNameTheirElements) {
  const std::string text = "[m]\npoly = [1.0, 'two', 3.0]\noffsets = [[0, 1], [5, 'x']]\n";
  auto err = [&](const std::function<void(TomlSection&)>& read) {
    return error_reading(text, [&](TomlSection& root) {
      TomlSection m = root.section("m");
      read(m);
    });
  };
  EXPECT_EQ(err([](TomlSection& m) { (void)m.array("poly").values<double>(); }), "f.toml:2: key 'm.poly[1]': expected a number, got a string 'two'");
  EXPECT_EQ(err([](TomlSection& m) { (void)m.array("offsets").array(1).get<double>(1); }),
            "f.toml:3: key 'm.offsets[1][1]': expected a number, got a string 'x'");
  EXPECT_EQ(err([](TomlSection& m) { m.array("poly").fail(2, "angles must increase"); }), "f.toml:2: key 'm.poly[2]': angles must increase");
  const toml::table t = pof::parse_toml("v = [1, 2, 3]\n", "f.toml");
  TomlSection root(t, "f.toml");
  EXPECT_EQ(root.array("v").values<int>(check::integer_in(0, 5)), (std::vector<int>{1, 2, 3}));
}

TEST(TomlReader, ValuesWithoutAFileAreNamedByTheSource) {
  // pof-daqd's -s key=value overrides are inserted into the file's table: they have no line.
  toml::table t = pof::parse_toml("[acquisition]\ndecimate = 10\n", "daq.toml");
  t["acquisition"].as_table()->insert_or_assign("decimate", 0);
  TomlSection root(t, "daq.toml + command line");
  const std::string e = error_of([&] {
    TomlSection a = root.section("acquisition");
    (void)a.get<int>("decimate", check::integer_in(1, 100));
  });
  EXPECT_EQ(e, "daq.toml + command line: key 'acquisition.decimate': expected an integer in [1, 100], got 0");
}

TEST(TomlReader, SyntaxErrorsNameTheLineAndStayShort) {
  EXPECT_EQ(error_of([] { (void)pof::parse_toml("a = 1\n[knee\n", "f.toml"); }).substr(0, 29), "f.toml:2: TOML syntax error: ");
  const std::string e = error_of([] { (void)pof::parse_toml("a = 1\n" + std::string(5000, 'x') + "\n", "f.toml"); });
  EXPECT_EQ(e.rfind("f.toml:2: TOML syntax error", 0), 0u) << e;
  EXPECT_LT(e.size(), 300u) << e;
  EXPECT_THROW((void)pof::read_toml_file("/nonexistent/x.toml", "test file"), pof::NoInputError);
}

// A FIFO (or socket) given as a configuration or calibration file is refused at once, naming it:
// opening one waited for a writer and stalled the reading loop. Devices read as before.
TEST(TextFile, AFifoIsRefusedWithoutWaiting) {
  pof::test::TempDir dir;
  const std::string fifo = dir.path("cal.toml");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    (void)pof::read_text_file(fifo, "calibration file");
    FAIL() << "a FIFO was read";
  } catch (const pof::NoInputError& e) {
    EXPECT_NE(std::string(e.what()).find("cal.toml: is a FIFO, expected a calibration file"), std::string::npos) << e.what();
  }
  EXPECT_EQ(pof::read_text_file("/dev/null", "configuration file"), "");
  std::ofstream(dir.path("a.toml")) << "a = 1\n";
  EXPECT_EQ(pof::read_text_file(dir.path("a.toml"), "test file"), "a = 1\n");
}

// The number formats every message and file uses (pof/base/format.hpp).
TEST(Format, NumbersAsText) {
  EXPECT_EQ(pof::format_number(0.1), "0.1");
  EXPECT_EQ(pof::format_number(1e300), "1e+300");
  EXPECT_EQ(pof::format_significant(2.0 / 3.0, 6), "0.666667");
  EXPECT_EQ(pof::format_significant(0.1, 17), "0.10000000000000001");
  EXPECT_EQ(pof::format_fixed(3.14159, 2), "3.14");
  EXPECT_EQ(pof::format_fixed(-0.5, 0), "-0");
  EXPECT_EQ(std::stod(pof::format_significant(1.0 / 3.0, 17)), 1.0 / 3.0);
}
