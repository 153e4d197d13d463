#include "pof/io/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>
#include <system_error>
#include <vector>

#include "pof/io/errors.hpp"

namespace pof::io {

AtomicFile::AtomicFile(std::filesystem::path dest) : dest_(std::move(dest)) {
  const std::filesystem::path dir = dest_.has_parent_path() ? dest_.parent_path() : std::filesystem::path(".");
  std::string pattern = (dir / ("." + dest_.filename().string() + ".tmp-XXXXXX")).string();
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  const int fd = ::mkstemp(buf.data());
  if (fd < 0)
    throw IoError(dest_.string() + ": cannot create a temporary file in '" + dir.string() + "': " + std::strerror(errno));
  // mkstemp makes 0600; a recording is an ordinary file (0666 & ~umask).
  const mode_t mask = ::umask(0);
  ::umask(mask);
  (void)::fchmod(fd, static_cast<mode_t>(0666 & ~mask));
  ::close(fd);
  tmp_ = buf.data();
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    std::filesystem::remove(tmp_, ec);
  }
}

void AtomicFile::commit() {
  const int fd = ::open(tmp_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0 || ::fsync(fd) != 0) {
    const int e = errno;
    if (fd >= 0) ::close(fd);
    throw IoError(dest_.string() + ": cannot sync '" + tmp_.string() + "': " + std::strerror(e));
  }
  ::close(fd);
  if (::rename(tmp_.c_str(), dest_.c_str()) != 0)
    throw IoError(dest_.string() + ": cannot rename '" + tmp_.string() + "' onto it: " + std::strerror(errno));
  committed_ = true;
}

}  // namespace pof::io
