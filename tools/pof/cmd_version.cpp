// `pof version`: what was built, from which sources, with which libraries. Lab notebooks and the
// session manifest quote this line.
#include <iostream>

#include <lcm/lcm-cpp.hpp>

#include "commands.hpp"

namespace pof::cli {

void add_version(CLI::App& app) {
  auto* cmd = app.add_subcommand("version", "Print the pofkit version and the library versions it was built with");
  cmd->callback([] {
    std::cout << "pofkit " << POF_VERSION << " (" << git_describe() << ")\n"
              << "lcm " << LCM_MAJOR_VERSION << '.' << LCM_MINOR_VERSION << '.' << LCM_MICRO_VERSION << '\n'
              << "compiler " << __VERSION__ << '\n';
  });
}

}  // namespace pof::cli
