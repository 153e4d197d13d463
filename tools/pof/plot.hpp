#pragma once
// Plots are drawn by the matplotlib scripts in tools/plot/, run with Debian's /usr/bin/python3
// (python3-matplotlib is a Debian package; a python3 earlier on PATH may lack it).
#include <string>
#include <vector>

namespace pof::cli {

/// Path of tools/plot/<script>: $POF_PLOT_DIR, else the source tree this binary was built from,
/// else the installed share directory. Empty when none has it.
std::string find_plot_script(const std::string& script);

/// Runs /usr/bin/python3 <script> <args...> and waits. Throws pof::IoError naming the script
/// when it is missing, cannot start or exits non-zero.
void run_plot_script(const std::string& script, const std::vector<std::string>& args);

}  // namespace pof::cli
