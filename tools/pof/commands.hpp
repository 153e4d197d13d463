#pragma once
// The `pof` CLI: one executable, one file per subcommand (cmd_<name>.cpp). Each file defines one
// add_<name>() that registers its subcommand on the app; main.cpp calls them all and runs the parse
// through pof::service::run_main, which maps what a subcommand throws to its exit code. `pof gap`
// is the one subcommand built as its own program, pof-gap (helper.cpp).
#include <CLI/CLI.hpp>

#include <string>

namespace pof::cli {

void add_version(CLI::App& app);
// `git describe` of the sources built: only git_describe.cpp sees it, so a commit recompiles one small file.
const char* git_describe();
void add_calibrate(CLI::App& app);
void add_compensate(CLI::App& app);
// `pof gap` is a helper program (helper.cpp): its summary, shown by `pof --help` and `pof-gap --help`,
// and the options and callback that pof-gap's main puts on its app.
inline constexpr const char* kGapSummary =
    "Find where the model and a recording disagree, name the missing effect, add it, show the gap shrink";
void setup_gap(CLI::App& app);
// A subcommand run by the program pof-<name> beside this one (helper.cpp), every argument after it passed on.
void add_helper(CLI::App& app, const std::string& name, const std::string& summary);
void add_sim(CLI::App& app);
void add_record(CLI::App& app);
void add_spy(CLI::App& app);
void add_dash(CLI::App& app);
void add_export(CLI::App& app);
void add_keygen(CLI::App& app);
void add_bridge(CLI::App& app);

}  // namespace pof::cli
