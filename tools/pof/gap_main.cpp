// pof-gap: the `pof gap` workflow as a program of its own (helper.cpp says why; cmd_gap.cpp is
// the command). `pof gap ARGS` runs it with ARGS; it also runs alone.
#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "pof/base/exit_codes.hpp"
#include "pof/service/run_main.hpp"

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("pof gap"));
  spdlog::set_pattern("pof gap: %^%l%$: %v");
  CLI::App app{"", "pof gap"};
  app.set_version_flag("--version", POF_VERSION);
  pof::cli::setup_gap(app);
  return pof::service::run_main("pof gap", app, argc, argv, [] { return pof::kExitOk; });
}
