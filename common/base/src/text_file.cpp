#include "pof/base/text_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "pof/base/errors.hpp"

namespace pof {

std::string read_text_file(const std::string& path, const std::string& what, std::size_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw NoInputError(path + ": cannot open " + what + ": " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISDIR(st.st_mode)) throw NoInputError(path + ": is a directory, expected a " + what);
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
