// pof: the command-line front end of pofkit. Subcommands live in cmd_*.cpp (see commands.hpp).
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "pof/base/errors.hpp"

int main(int argc, char** argv) {
  // Diagnostics go to stderr: stdout carries results (tables, CSV, `pof record --check`,
  // `pof spy --once`) that scripts parse.
  spdlog::set_default_logger(spdlog::stderr_color_mt("pof"));
  spdlog::set_pattern("pof: %^%l%$: %v");
  CLI::App app{"pof: calibrate, simulate, compensate and inspect POF knee-angle sensor data"};
  app.require_subcommand(1);
  app.set_version_flag("--version", POF_VERSION);
  pof::cli::add_version(app);
  pof::cli::add_calibrate(app);
  pof::cli::add_compensate(app);
  pof::cli::add_gap(app);
  pof::cli::add_sim(app);
  pof::cli::add_record(app);
  pof::cli::add_spy(app);
  pof::cli::add_export(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // CLI11 prints help/usage itself; its usage errors are exit 2 like every other pofkit tool.
    const int rc = app.exit(e);
    return rc == 0 ? 0 : pof::kExitUsage;
  } catch (const pof::Error& e) {
    spdlog::error("{}", e.what());
    return e.code();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return pof::kExitIoErr;
  }
  return 0;
}
