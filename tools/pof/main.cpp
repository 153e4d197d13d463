// pof: the command-line front end of pofkit. Subcommands live in cmd_*.cpp (see commands.hpp).
#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "pof/base/exit_codes.hpp"
#include "pof/service/run_main.hpp"

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
  pof::cli::add_helper(app, "gap", pof::cli::kGapSummary);  // the program pof-gap
  pof::cli::add_sim(app);
  pof::cli::add_record(app);
  pof::cli::add_spy(app);
  pof::cli::add_dash(app);
  pof::cli::add_export(app);
  pof::cli::add_keygen(app);
  pof::cli::add_bridge(app);

  // The subcommands run inside the parse (their callbacks), so their exceptions go through
  // run_main's table too.
  return pof::service::run_main("pof", app, argc, argv, [] { return pof::kExitOk; });
}
