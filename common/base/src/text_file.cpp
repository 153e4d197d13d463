#include "pof/base/text_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "pof/base/errors.hpp"

namespace pof {

std::string read_text_file(const std::string& path, const std::string& what, std::size_t max_bytes) {
  // Opened without blocking: opening a FIFO waits for a writer, which stalled the loop that reads
  // (pof-daqd's start, pof-compensatord's reload on SIGHUP). Only then is its kind known.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw NoInputError(path + ": cannot open " + what + ": " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) == 0) {
    if (S_ISDIR(st.st_mode)) throw NoInputError(path + ": is a directory, expected a " + what);
    if (S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode))
      throw NoInputError(path + ": is a " + (S_ISFIFO(st.st_mode) ? "FIFO" : "socket") + ", expected a " + what +
                         " (a regular file: reading a pipe would wait on its writer)");
  }
  // Files and devices read as before: blocking (a device such as /dev/null ends at once).
  if (const int flags = ::fcntl(fd, F_GETFL); flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  std::string text;
  for (;;) {
    const std::size_t at = text.size();
    text.resize(at + 64 * 1024);
    const ssize_t r = ::read(fd, text.data() + at, text.size() - at);
    if (r < 0 && errno == EINTR) {
      text.resize(at);
      continue;
    }
    if (r < 0) throw IoError(path + ": read error: " + std::strerror(errno));
    text.resize(at + static_cast<std::size_t>(r));
    if (r == 0) break;
    if (text.size() > max_bytes)
      throw ConfigError(path + ": longer than " + std::to_string(max_bytes >> 10) + " KiB: not a " + what);
  }
  return text;
}

}  // namespace pof
