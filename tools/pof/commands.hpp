#pragma once
// The `pof` CLI: one executable, one file per subcommand (cmd_<name>.cpp). Each file defines one
// add_<name>() that registers its subcommand on the app; main.cpp calls them all and runs the parse
// through pof::service::run_main, which maps what a subcommand throws to its exit code.
#include <CLI/CLI.hpp>

namespace pof::cli {

void add_version(CLI::App& app);
// `git describe` of the sources built: only git_describe.cpp sees it, so a commit recompiles one small file.
const char* git_describe();
void add_calibrate(CLI::App& app);
void add_compensate(CLI::App& app);
void add_gap(CLI::App& app);
void add_sim(CLI::App& app);
void add_record(CLI::App& app);
void add_spy(CLI::App& app);
void add_dash(CLI::App& app);
void add_export(CLI::App& app);
void add_keygen(CLI::App& app);
void add_bridge(CLI::App& app);

}  // namespace pof::cli
