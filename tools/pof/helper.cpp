// Subcommands built as programs of their own, git-style: `pof gap ARGS` runs `pof-gap ARGS`, found
// beside this binary (build/bin, or /usr/bin of the .deb). The gap workflow is a fifth of the CLI's
// compile time and a library only it uses; built apart, `pof` does not wait for it, and the demo,
// which never runs it, does not build it (docs/architecture.md, "Programs").
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "commands.hpp"
#include "plot.hpp"
#include "pof/base/errors.hpp"

namespace pof::cli {

namespace {

std::filesystem::path helper_path(const std::string& name) {
  const std::filesystem::path bin = own_folder();
  if (bin.empty()) throw pof::IoError("cannot find this program's own folder (/proc/self/exe)");
  return bin / ("pof-" + name);
}

}  // namespace

void add_helper(CLI::App& app, const std::string& name, const std::string& summary) {
  auto* cmd = app.add_subcommand(name, summary);
  // Every argument after the name, --help included, is the helper's to parse.
  cmd->prefix_command();
  cmd->set_help_flag();
  cmd->callback([cmd, name] {
    const std::filesystem::path path = helper_path(name);
    std::vector<std::string> args{"pof " + name};
    for (const std::string& a : cmd->remaining()) args.push_back(a);
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(path.c_str(), argv.data());
    const int err = errno;
    if (err == ENOENT)
      throw pof::ConfigError("'pof " + name + "' runs the program " + path.string() +
                             ", which is not there: build it (cmake --build build --target pof-" + name +
                             ") or install the pofkit package");
    throw pof::IoError(path.string() + ": cannot run: " + std::strerror(err));
  });
}

}  // namespace pof::cli
