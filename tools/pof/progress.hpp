#pragma once
// Progress for long work: on a terminal only (stderr is a TTY), one self-overwriting line; nothing
// in pipes, logs or CI, where it would only be noise.
#include <unistd.h>

#include <cstdio>
#include <string>

namespace pof::cli {

class Progress {
 public:
  explicit Progress(std::string what) : what_(std::move(what)), on_(::isatty(STDERR_FILENO) == 1) {}
  ~Progress() { done(); }
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void stage(const std::string& s) {
    if (!on_) return;
    std::fprintf(stderr, "\r\033[K%s: %s", what_.c_str(), s.c_str());
    std::fflush(stderr);
    dirty_ = true;
  }
  void fraction(long i, long n) {
    if (!on_ || n <= 0) return;
    const int pct = static_cast<int>(100 * i / n);
    if (pct == last_pct_) return;
    last_pct_ = pct;
    stage(std::to_string(pct) + " %");
  }
  void done() {
    if (on_ && dirty_) std::fprintf(stderr, "\r\033[K");
    dirty_ = false;
  }

 private:
  std::string what_;
  bool on_;
  bool dirty_ = false;
  int last_pct_ = -1;
};

}  // namespace pof::cli
