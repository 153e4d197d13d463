// pof::service::run_main: the one exception -> exit code table of every pofkit binary, and the
// "<program>: error: <what>" line it prints (e2e scripts grep it).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <ios>
#include <new>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include <CLI/CLI.hpp>

#include "pof/base/errors.hpp"
#include "pof/service/cli_checks.hpp"
#include "pof/service/run_main.hpp"

namespace {

struct Outcome {
  int code;
  std::string err;
};

template <class F>
Outcome run(F body) {
  testing::internal::CaptureStderr();
  const int code = pof::service::run_main("prog", [&]() -> int { return body(); });
  return {code, testing::internal::GetCapturedStderr()};
}

template <class E>
Outcome run_throwing(const E& e) {
  return run([&]() -> int { throw e; });
}

}  // namespace

TEST(RunMain, BodyResultPassesThroughSilently) {
  const Outcome o = run([] { return 3; });
  EXPECT_EQ(o.code, 3);
  EXPECT_EQ(o.err, "");
}

TEST(RunMain, PofErrorsCarryTheirCode) {
  struct Case {
    Outcome got;
    int code;
  };
  const std::vector<Case> cases = {
      {run_throwing(pof::UsageError("out.csv is an input")), 2},
      {run_throwing(pof::DataError("run.csv:17: column sensor_v: expected a number")), 65},
      {run_throwing(pof::NoInputError("missing.toml: no such file")), 66},
      {run_throwing(pof::IoError("out.csv: disk full")), 74},
      {run_throwing(pof::ConfigError("cal.toml: key 'c9': expected a finite number")), 78},
      {run_throwing(pof::Error(pof::kExitConfig, "base class")), 78},
  };
  for (const auto& c : cases) EXPECT_EQ(c.got.code, c.code) << c.got.err;
  EXPECT_EQ(cases[1].got.err, "prog: error: run.csv:17: column sensor_v: expected a number\n");
  EXPECT_EQ(cases[4].got.err, "prog: error: cal.toml: key 'c9': expected a finite number\n");
}

TEST(RunMain, RejectedConfigurationValuesAre78) {
  Outcome o = run_throwing(std::invalid_argument("compensator: velocity window too long"));
  EXPECT_EQ(o.code, 78);
  EXPECT_EQ(o.err, "prog: error: compensator: velocity window too long\n");
  o = run_throwing(std::out_of_range("stoi"));
  EXPECT_EQ(o.code, 78);
  EXPECT_EQ(o.err, "prog: error: stoi\n");
}

TEST(RunMain, ResourceAndSystemFailuresAre74) {
  Outcome o = run_throwing(std::bad_alloc());
  EXPECT_EQ(o.code, 74);
  EXPECT_EQ(o.err, "prog: error: out of memory (std::bad_alloc)\n");
  o = run_throwing(std::system_error(std::make_error_code(std::errc::no_space_on_device), "write out.csv"));
  EXPECT_EQ(o.code, 74);
  EXPECT_NE(o.err.find("prog: error: write out.csv: "), std::string::npos) << o.err;
  EXPECT_EQ(o.err.find("internal error"), std::string::npos) << o.err;
  o = run_throwing(std::ios_base::failure("stream failed"));
  EXPECT_EQ(o.code, 74);
  EXPECT_EQ(o.err.find("internal error"), std::string::npos) << o.err;
  o = run_throwing(std::filesystem::filesystem_error("rename", std::make_error_code(std::errc::permission_denied)));
  EXPECT_EQ(o.code, 74);
  EXPECT_EQ(o.err.find("internal error"), std::string::npos) << o.err;
}

TEST(RunMain, AnythingElseIsAnInternalError74) {
  Outcome o = run_throwing(std::runtime_error("unexpected"));
  EXPECT_EQ(o.code, 74);
  EXPECT_EQ(o.err, "prog: error: internal error: unexpected\n");
  o = run_throwing(std::logic_error("broken invariant"));
  EXPECT_EQ(o.code, 74);
  EXPECT_EQ(o.err, "prog: error: internal error: broken invariant\n");
  o = run_throwing(42);
  EXPECT_EQ(o.code, 74);
  EXPECT_EQ(o.err.rfind("prog: error: internal error: ", 0), 0u) << o.err;
}

TEST(RunMain, ParseErrorWithoutAnAppIsUsage) {
  const Outcome o = run_throwing(CLI::ValidationError("--rate", "must be positive"));
  EXPECT_EQ(o.code, 2);
  EXPECT_EQ(o.err.rfind("prog: error: ", 0), 0u) << o.err;
  EXPECT_NE(o.err.find("--rate"), std::string::npos) << o.err;
}

namespace {

struct CliOutcome {
  int code;
  std::string out, err;
  bool body_ran = false;
};

// A small app: an option, --version, and a subcommand whose callback throws `sub_error`.
CliOutcome run_cli(std::vector<const char*> args, const std::function<int()>& body = [] { return 0; }) {
  CLI::App app{"test app", "prog"};
  app.set_version_flag("--version", "9.9.9");
  double rate = 1;
  app.add_option("--rate", rate)->check(CLI::PositiveNumber);
  auto* sub = app.add_subcommand("bad-data", "throws a DataError");
  sub->callback([] { throw pof::DataError("in.csv:3: expected a number"); });
  args.insert(args.begin(), "prog");
  CliOutcome r{};
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  r.code = pof::service::run_main("prog", app, static_cast<int>(args.size()), args.data(), [&] {
    r.body_ran = true;
    return body();
  });
  r.err = testing::internal::GetCapturedStderr();
  r.out = testing::internal::GetCapturedStdout();
  return r;
}

}  // namespace

TEST(RunMainCli, HelpAndVersionExit0AndSkipTheBody) {
  CliOutcome r = run_cli({"--help"});
  EXPECT_EQ(r.code, 0);
  EXPECT_FALSE(r.body_ran);
  EXPECT_NE(r.out.find("Usage: prog"), std::string::npos) << r.out;
  r = run_cli({"--version"});
  EXPECT_EQ(r.code, 0);
  EXPECT_FALSE(r.body_ran);
  EXPECT_NE(r.out.find("9.9.9"), std::string::npos) << r.out;
}

TEST(RunMainCli, ParseErrorsExit2WithCli11sMessage) {
  CliOutcome r = run_cli({"--no-such-flag"});
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(r.body_ran);
  EXPECT_NE(r.err.find("--no-such-flag"), std::string::npos) << r.err;
  r = run_cli({"--rate", "-5"});
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(r.body_ran);
}

TEST(RunMainCli, ValidationInTheBodyIsAParseError) {
  const CliOutcome r = run_cli({"--rate", "5"}, []() -> int { throw CLI::ValidationError("--rate", "too fast"); });
  EXPECT_TRUE(r.body_ran);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("too fast"), std::string::npos) << r.err;
}

TEST(RunMainCli, BodyAndSubcommandExceptionsGoThroughTheTable) {
  CliOutcome r = run_cli({"--rate", "5"}, []() -> int { throw pof::ConfigError("daq.toml: key 'x': bad"); });
  EXPECT_EQ(r.code, 78);
  EXPECT_EQ(r.err, "prog: error: daq.toml: key 'x': bad\n");
  r = run_cli({"bad-data"});
  EXPECT_EQ(r.code, 65);
  EXPECT_EQ(r.err, "prog: error: in.csv:3: expected a number\n");
  r = run_cli({"--rate", "5"}, [] { return 0; });
  EXPECT_EQ(r.code, 0);
  EXPECT_TRUE(r.body_ran);
  EXPECT_EQ(r.err, "");
}

// The number checks every command line uses: NaN, infinity, the wrong sign and a value beyond the
// bound are parse errors (exit 2) naming the option; CLI11's own checks let NaN and inf through.
TEST(CliChecks, NumbersMustBeFiniteAndInRange) {
  auto parse = [](const std::string& value, const CLI::Validator& check) {
    CLI::App app{"t"};
    double x = 0;
    app.add_option("--x", x)->check(check);
    std::vector<std::string> args{"--x", value};
    std::reverse(args.begin(), args.end());  // CLI11 takes them last first
    try {
      app.parse(args);
      return std::string("ok");
    } catch (const CLI::ParseError& e) {
      EXPECT_EQ(e.get_exit_code(), static_cast<int>(CLI::ExitCodes::ValidationError));
      return std::string(e.what());
    }
  };
  const CLI::Validator seconds = pof::service::non_negative(pof::service::kMaxSeconds);
  EXPECT_EQ(parse("0", seconds), "ok");
  EXPECT_EQ(parse("2.5", seconds), "ok");
  for (const char* bad : {"nan", "-nan", "inf", "-1", "1e10", "x"}) {
    const std::string why = parse(bad, seconds);
    EXPECT_NE(why, "ok") << bad;
    EXPECT_NE(why.find("--x"), std::string::npos) << why;
  }
  const CLI::Validator rate = pof::service::positive();
  EXPECT_EQ(parse("200", rate), "ok");
  for (const char* bad : {"0", "-200", "nan", "inf"}) EXPECT_NE(parse(bad, rate), "ok") << bad;
  // What CLI11's own check lets through.
  EXPECT_EQ(parse("nan", CLI::NonNegativeNumber), "ok");
}
