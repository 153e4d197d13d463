#include "plot.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "pof/io/errors.hpp"

extern char** environ;

namespace pof::cli {

std::string find_plot_script(const std::string& script) {
  const char* const dirs[] = {std::getenv("POF_PLOT_DIR"), POF_PLOT_DIR_SOURCE, POF_PLOT_DIR_INSTALLED};
  for (const char* dir : dirs) {
    if (dir == nullptr) continue;
    const std::string p = std::string(dir) + "/" + script;
    if (::access(p.c_str(), R_OK) == 0) return p;
  }
  return {};
}

void run_plot_script(const std::string& script, const std::vector<std::string>& args) {
  const std::string path = find_plot_script(script);
  if (path.empty()) throw io::IoError(script + ": plot script not found (set POF_PLOT_DIR to the tools/plot folder)");
  std::vector<std::string> all{"/usr/bin/python3", path};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (const int rc = ::posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ); rc != 0)
    throw io::IoError(path + ": cannot start /usr/bin/python3: " + std::strerror(rc));
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw io::IoError(path + ": plotting failed (exit status " +
                      std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
}

}  // namespace pof::cli
