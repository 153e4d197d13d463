#pragma once
// Plots are drawn by the matplotlib scripts in tools/plot/, run with Debian's /usr/bin/python3
// (python3-matplotlib is a Debian package; a python3 earlier on PATH may lack it).
#include <filesystem>
#include <string>
#include <vector>

namespace pof::cli {

/// The folder this binary runs from (/proc/self/exe's), where its helpers and, one level up, its
/// share folders are; empty when the kernel does not say.
std::filesystem::path own_folder();

/// Path of `file` in one of pofkit's shared folders: $<env_var>, else <prefix>/<installed_relative>
/// for the prefix this binary runs from, else `source_dir` (a build tree). Empty when none has it.
std::string find_share_file(const char* env_var, const std::string& installed_relative, const std::string& source_dir,
                            const std::string& file);

/// Path of tools/plot/<script>: $POF_PLOT_DIR, else the source tree this binary was built from,
/// else the installed share directory. Empty when none has it.
std::string find_plot_script(const std::string& script);

/// Runs /usr/bin/python3 <script> <args...> and waits. Throws pof::IoError naming the script
/// when it is missing, cannot start or exits non-zero.
void run_plot_script(const std::string& script, const std::vector<std::string>& args);

}  // namespace pof::cli
