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

#include "pof/base/errors.hpp"

namespace pof::io {

AtomicFile::AtomicFile(std::filesystem::path dest, mode_t permissions, Replace replace)
    : dest_(std::move(dest)), replace_(replace) {
  // A destination that is there and is not a regular file (a character device such as /dev/null,
  // a FIFO a reader waits on) is written in place: there is no file to replace, and a rename over
  // it replaces the node itself (as root, `pof compensate --csv /dev/null` left /dev/null a
  // regular file, and every later `> /dev/null` on the machine wrote into it).
  if (struct stat st {}; ::stat(dest_.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    if (S_ISDIR(st.st_mode)) throw IoError(dest_.string() + ": is a directory; expected a file to write");
    if (replace == Replace::kNo) throw IoError(dest_.string() + ": exists; not overwritten");
    in_place_ = true;
    tmp_ = dest_;
    return;
  }
  const std::filesystem::path dir = dest_.has_parent_path() ? dest_.parent_path() : std::filesystem::path(".");
  std::string pattern = (dir / ("." + dest_.filename().string() + ".tmp-XXXXXX")).string();
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  const int fd = ::mkstemp(buf.data());
  if (fd < 0)
    throw IoError(dest_.string() + ": cannot create a temporary file in '" + dir.string() + "': " + std::strerror(errno));
  // mkstemp makes 0600; a recording is an ordinary file (0666 & ~umask), a key keeps 0600.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  (void)::fchmod(fd, static_cast<mode_t>(permissions & 0777 & ~mask));
  ::close(fd);
  tmp_ = buf.data();
}

AtomicFile::~AtomicFile() {
  if (!committed_ && !in_place_) {
    std::error_code ec;
    std::filesystem::remove(tmp_, ec);
  }
}

void AtomicFile::commit() {
  if (in_place_) {  // written straight into the device or pipe: nothing to sync or rename
    committed_ = true;
    return;
  }
  const int fd = ::open(tmp_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0 || ::fsync(fd) != 0) {
    const int e = errno;
    if (fd >= 0) ::close(fd);
    throw IoError(dest_.string() + ": cannot sync '" + tmp_.string() + "': " + std::strerror(e));
  }
  ::close(fd);
  if (replace_ == Replace::kNo) {
    // link(2) refuses an existing name (EEXIST), atomically; rename(2) would replace it.
    if (::link(tmp_.c_str(), dest_.c_str()) != 0) {
      const int e = errno;
      throw IoError(dest_.string() + (e == EEXIST ? ": exists; not overwritten" : ": cannot link '" + tmp_.string() +
                                                                                      "' to it: " + std::strerror(e)));
    }
    ::unlink(tmp_.c_str());
    committed_ = true;
    return;
  }
  if (::rename(tmp_.c_str(), dest_.c_str()) != 0)
    throw IoError(dest_.string() + ": cannot rename '" + tmp_.string() + "' onto it: " + std::strerror(errno));
  committed_ = true;
}

void write_file_atomic(const std::filesystem::path& path, const std::string& content, mode_t permissions,
                       Replace replace) {
  AtomicFile file(path, permissions, replace);
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

namespace {

// Identity of a path: the inode when it exists, else its absolute normalised spelling.
struct FileId {
  bool exists = false;
  bool shared_ok = false;  // a character device (/dev/null, a tty): written in place, whatever was written before
  dev_t dev = 0;
  ino_t ino = 0;
  std::filesystem::path spelled;
  bool operator==(const FileId& o) const {
    return exists == o.exists && (exists ? dev == o.dev && ino == o.ino : spelled == o.spelled);
  }
};

FileId file_id(const std::filesystem::path& p) {
  FileId id;
  struct stat st {};
  if (::stat(p.c_str(), &st) == 0) {
    id.exists = true;
    id.shared_ok = S_ISCHR(st.st_mode);
    id.dev = st.st_dev;
    id.ino = st.st_ino;
  } else {
    std::error_code ec;
    id.spelled = std::filesystem::weakly_canonical(std::filesystem::absolute(p, ec), ec);
    if (ec) id.spelled = std::filesystem::absolute(p).lexically_normal();
  }
  return id;
}

bool skipped(const NamedPath& p) { return p.path.empty() || p.path == "-"; }

}  // namespace

void refuse_output_over_input(const std::vector<NamedPath>& inputs, const std::vector<NamedPath>& outputs) {
  std::vector<FileId> out_ids;
  for (const auto& o : outputs) out_ids.push_back(skipped(o) ? FileId{} : file_id(o.path));
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const NamedPath& o = outputs[i];
    if (skipped(o)) continue;
    for (const auto& in : inputs) {
      if (skipped(in)) continue;
      const FileId id = file_id(in.path);
      if (id.exists && id == out_ids[i])
        throw UsageError(o.option + " " + o.path.string() + ": is the same file as the input " + in.option + " " +
                         in.path.string() + "; refusing to overwrite an input (choose another output file)");
    }
    // Two outputs on one character device (--csv /dev/null --json /dev/null) are each written to
    // it, and neither takes the other's place. A pipe is not exempt (its reader would get both
    // outputs run together, or stop at the first one's end), nor is a block device (each output
    // is written from its start).
    for (std::size_t j = 0; j < i; ++j)
      if (!skipped(outputs[j]) && out_ids[j] == out_ids[i] && !out_ids[i].shared_ok)
        throw UsageError(o.option + " " + o.path.string() + ": is the same file as " + outputs[j].option + " " +
                         outputs[j].path.string() + "; each output needs its own file");
  }
}

}  // namespace pof::io
