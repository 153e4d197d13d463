#include "plot.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "pof/base/errors.hpp"

extern char** environ;

namespace pof::cli {

std::filesystem::path own_folder() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path() : exe.parent_path();
}

std::string find_share_file(const char* env_var, const std::string& installed_relative, const std::string& source_dir,
                            const std::string& file) {
  // In order: the user's override, the installed copy next to this binary, and the source tree
  // when running from a build directory (build/bin has no share/ beside it). The installed copy is
  // <prefix>/<installed_relative> for the prefix this binary runs from (<prefix>/bin/pof): an
  // install with `cmake --install --prefix P`, a .deb (/usr) or an unpacked package all find their
  // own files, whatever prefix the build was configured with.
  const char* env = std::getenv(env_var);
  std::string installed;
  if (const std::filesystem::path bin = own_folder(); !bin.empty())
    installed = (bin.parent_path() / installed_relative).string();
  const std::string dirs[] = {env != nullptr ? env : "", installed, source_dir};
  for (const std::string& dir : dirs) {
    if (dir.empty()) continue;
    const std::string p = dir + "/" + file;
    if (::access(p.c_str(), R_OK) == 0) return p;
  }
  return {};
}

std::string find_plot_script(const std::string& script) {
  return find_share_file("POF_PLOT_DIR", POF_PLOT_DIR_RELATIVE, POF_PLOT_DIR_SOURCE, script);
}

void run_plot_script(const std::string& script, const std::vector<std::string>& args) {
  const std::string path = find_plot_script(script);
  if (path.empty()) throw pof::IoError(script + ": plot script not found (set POF_PLOT_DIR to the tools/plot folder)");
  std::vector<std::string> all{"/usr/bin/python3", path};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (const int rc = ::posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ); rc != 0)
    throw pof::IoError(path + ": cannot start /usr/bin/python3: " + std::strerror(rc));
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw pof::IoError(path + ": plotting failed (exit status " +
                      std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
}

}  // namespace pof::cli
