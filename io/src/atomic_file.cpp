#include "pof/io/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
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

void write_file_atomic(const std::filesystem::path& path, const std::string& content) {
  AtomicFile file(path);
  const int fd = ::open(file.temp_path().c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  if (fd < 0) throw IoError(path.string() + ": cannot open '" + file.temp_path().string() + "': " + std::strerror(errno));
  std::size_t done = 0;
  while (done < content.size()) {
    const ssize_t w = ::write(fd, content.data() + done, content.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {  // a regular file that takes 0 bytes is full
      const int e = w < 0 ? errno : ENOSPC;
      ::close(fd);
      throw IoError(path.string() + ": write failed: " + std::strerror(e));
    }
    done += static_cast<std::size_t>(w);
  }
  if (::close(fd) != 0) throw IoError(path.string() + ": close failed: " + std::strerror(errno));
  file.commit();  // fsync + rename; the destructor removes the temporary file on any throw above
}

void write_output(const std::filesystem::path& path, const std::string& content) {
  if (path != "-") {
    write_file_atomic(path, content);
    return;
  }
  if (std::fwrite(content.data(), 1, content.size(), stdout) != content.size() || std::fflush(stdout) != 0)
    throw IoError(std::string("standard output: write error: ") + std::strerror(errno));
}

}  // namespace pof::io
