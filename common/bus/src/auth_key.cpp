// The bus key file; the rules are in pof/bus/auth_key.hpp.
#include "pof/bus/auth_key.hpp"

#include <fcntl.h>
#include <sodium.h>
#include <sys/stat.h>
#include <sys/xattr.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "pof/base/errors.hpp"

namespace pof::bus::auth {
namespace {

// Tags and the version of include/uapi/linux/posix_acl_xattr.h and posix_acl.h.
constexpr std::uint32_t kAclVersion = 2;
constexpr std::uint16_t kAclUserObj = 0x01, kAclUser = 0x02, kAclGroupObj = 0x04, kAclGroup = 0x08, kAclMask = 0x10,
                        kAclOther = 0x20;

// Longest key file worth reading: 64 hex digits and "\r\n", plus one byte to see that it is longer.
constexpr std::size_t kMaxKeyFileBytes = 67;

int hex_digit(unsigned char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::string mode_text(mode_t mode) {
  char b[8];
  std::snprintf(b, sizeof b, "%04o", static_cast<unsigned>(mode & 07777));
  return b;
}

// Wipes a buffer on every way out of load_key_file().
struct Wiped {
  unsigned char* p;
  std::size_t n;
  ~Wiped() { sodium_memzero(p, n); }
};

}  // namespace

std::string resolve_key_file(const std::string& option) {
  if (!option.empty()) return option;
  const char* env = std::getenv(kKeyFileEnv);
  return env != nullptr ? env : "";
}

std::optional<std::vector<unsigned char>> parse_key_bytes(const unsigned char* data, std::size_t size) {
  if (size == Key::kBytes) return std::vector<unsigned char>(data, data + size);
  std::size_t n = size;
  if (n > 0 && data[n - 1] == '\n') --n;
  if (n > 0 && data[n - 1] == '\r') --n;
  if (n != 2 * Key::kBytes) return std::nullopt;
  std::vector<unsigned char> key(Key::kBytes);
  for (std::size_t i = 0; i < Key::kBytes; ++i) {
    const int hi = hex_digit(data[2 * i]), lo = hex_digit(data[2 * i + 1]);
    if (hi < 0 || lo < 0) {
      sodium_memzero(key.data(), key.size());
      return std::nullopt;
    }
    key[i] = static_cast<unsigned char>(hi * 16 + lo);
  }
  return key;
}

std::optional<std::vector<AclEntry>> parse_posix_acl(const unsigned char* data, std::size_t size) {
  const auto le = [](const unsigned char* p, int n) {
    std::uint32_t v = 0;
    for (int i = n - 1; i >= 0; --i) v = (v << 8) | p[i];
    return v;
  };
  if (size < 4 || (size - 4) % 8 != 0 || le(data, 4) != kAclVersion) return std::nullopt;
  std::vector<AclEntry> out;
  for (std::size_t at = 4; at < size; at += 8)
    out.push_back(AclEntry{static_cast<std::uint16_t>(le(data + at, 2)), static_cast<std::uint16_t>(le(data + at + 2, 2)),
                           le(data + at + 4, 4)});
  return out;
}

std::string key_access_problem(uid_t owner, mode_t mode, const std::vector<AclEntry>* acl, uid_t euid) {
  if (owner != 0 && owner != euid)
    return "owned by uid " + std::to_string(owner) + ", neither root nor the user running this process (uid " +
           std::to_string(euid) + ")";
  if (acl == nullptr || acl->empty()) {
    if ((mode & 077) != 0) return "mode " + mode_text(mode) + " gives group or others access";
    return "";
  }
  // With an ACL the group bits of the mode are its mask (acl(5)): what a named user or any group
  // entry may do is its permissions and the mask.
  std::uint16_t mask = 07;
  for (const AclEntry& e : *acl)
    if (e.tag == kAclMask) mask = e.perm;
  for (const AclEntry& e : *acl) {
    const std::string where = "mode " + mode_text(mode) + " with an ACL that ";
    switch (e.tag) {
      case kAclUserObj:
      case kAclMask: break;
      case kAclUser:
        if (e.id != 0 && e.id != euid && (e.perm & mask) != 0)
          return where + "gives user " + std::to_string(e.id) + " access";
        break;
      case kAclGroupObj:
        if ((e.perm & mask) != 0) return where + "gives the owning group access";
        break;
      case kAclGroup:
        if ((e.perm & mask) != 0) return where + "gives group " + std::to_string(e.id) + " access";
        break;
      case kAclOther:
        if (e.perm != 0) return where + "gives others access";
        break;
      default: return where + "has an entry of unknown type " + std::to_string(e.tag);
    }
  }
  return "";
}

std::shared_ptr<const Key> load_key_file(const std::string& path) {
  const std::string what = "bus key file '" + path + "'";
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) throw ConfigError(what + ": cannot open: " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw ConfigError(what + ": cannot stat: " + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) throw ConfigError(what + ": not a regular file");
  // The checks apply to the file opened (fstat, fgetxattr), not to whatever the path names later.
  std::vector<AclEntry> acl;
  unsigned char xattr[512];
  const ssize_t xn = ::fgetxattr(fd, "system.posix_acl_access", xattr, sizeof xattr);
  if (xn >= 0) {
    const auto parsed = parse_posix_acl(xattr, static_cast<std::size_t>(xn));
    if (!parsed) throw ConfigError(what + ": its POSIX ACL cannot be read; remove it (setfacl -b) and chmod 600");
    acl = *parsed;
  } else if (errno == ERANGE) {
    throw ConfigError(what + ": its POSIX ACL is too long to check; remove it (setfacl -b) and chmod 600");
  }
  const std::string problem = key_access_problem(st.st_uid, st.st_mode, acl.empty() ? nullptr : &acl, ::geteuid());
  if (!problem.empty())
    throw ConfigError(what + ": " + problem + "; a bus key must be owned by root or by the user running the "
                      "process and be readable by its owner only (chown, chmod 600" +
                      std::string(acl.empty() ? "" : ", setfacl -b") + "; docs/deployment.md, \"Authenticated mode\")");
  unsigned char buf[kMaxKeyFileBytes];
  const Wiped wipe_buf{buf, sizeof buf};
  std::size_t n = 0;
  while (n < sizeof buf) {
    const ssize_t r = ::read(fd, buf + n, sizeof buf - n);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) throw ConfigError(what + ": cannot read: " + std::strerror(errno));
    if (r == 0) break;
    n += static_cast<std::size_t>(r);
  }
  std::optional<std::vector<unsigned char>> key = parse_key_bytes(buf, n);
  if (!key)
    throw ConfigError(what + ": expected 32 bytes, or 64 hex digits and a line end (pof keygen writes one), got " +
                      std::string(n == sizeof buf ? "more than 66" : std::to_string(n)) + " bytes that are neither");
  const Wiped wipe_key{key->data(), key->size()};
  // All zeros is the one key anyone would guess first (a file made by dd from /dev/zero, or
  // 64 '0's typed in): it authenticates nothing.
  if (sodium_is_zero(key->data(), key->size()) == 1)
    throw ConfigError(what + ": the key is all zeros, which anyone can guess; pof keygen -o FILE writes a random one");
  return std::make_shared<const Key>(key->data(), key->size());
}

std::string new_key_text() {
  unsigned char key[Key::kBytes];
  const Wiped wipe{key, sizeof key};
  if (sodium_init() < 0) throw IoError("libsodium could not be initialised (sodium_init)");
  randombytes_buf(key, sizeof key);
  char hex[2 * Key::kBytes + 1];
  sodium_bin2hex(hex, sizeof hex, key, sizeof key);
  std::string text(hex, 2 * Key::kBytes);
  sodium_memzero(hex, sizeof hex);
  return text + "\n";
}

void wipe(std::string& s) { sodium_memzero(s.data(), s.size()); }

}  // namespace pof::bus::auth
