#pragma once
// The bus key file of the authenticated mode (pof/bus/auth.hpp; docs/deployment.md, "Authenticated
// mode"): which file a process uses, reading it, and making a new one (`pof keygen`).
//
// Which file: the --auth-key-file option (pof-daqd: also lcm.auth_key_file of its configuration
// file), else $POF_LCM_AUTH_KEY_FILE (the units take it from /etc/pof/pof.env, or from the
// systemd credential drop-in deploy/systemd/lcm-auth.conf), else none: the bus is unauthenticated,
// as it always was. The same precedence as the LCM URL (pof/bus/url.hpp).
//
// The file: 32 bytes, or 64 hex digits (what `pof keygen` writes) with an optional line end. It
// must be a regular file owned by root or by the user running the process, and give nobody else
// any access: no permission bits for group or others and, with a POSIX ACL (systemd hands a
// LoadCredential= copy to a service user that way on a file system with ACLs), no entry for another
// user, a group or others that the mask lets through. Every refusal is a ConfigError (exit 78)
// naming the file and, for access, its owner and mode.
#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "pof/bus/auth.hpp"

namespace pof::bus::auth {

inline constexpr const char* kKeyFileEnv = "POF_LCM_AUTH_KEY_FILE";

/// The key file a process uses: `option`, else $POF_LCM_AUTH_KEY_FILE, else "" (unauthenticated).
std::string resolve_key_file(const std::string& option);

/// Reads and checks the key file (see above). Throws ConfigError naming the file.
std::shared_ptr<const Key> load_key_file(const std::string& path);

/// The key in a key file's bytes: 32 bytes, or 64 hex digits and an optional "\n" or "\r\n";
/// nullopt otherwise (the bytes are wiped by the caller).
std::optional<std::vector<unsigned char>> parse_key_bytes(const unsigned char* data, std::size_t size);

/// A new random key as a key file holds it: 64 lower-case hex digits and "\n" (`pof keygen`).
std::string new_key_text();
/// Overwrites `s` with zeros in a way the compiler keeps (sodium_memzero): key text, once used.
void wipe(std::string& s);

/// One entry of a POSIX access ACL (the system.posix_acl_access extended attribute, as the Linux
/// kernel stores it: include/uapi/linux/posix_acl_xattr.h).
struct AclEntry {
  std::uint16_t tag = 0;  // ACL_USER_OBJ 1, ACL_USER 2, ACL_GROUP_OBJ 4, ACL_GROUP 8, ACL_MASK 0x10, ACL_OTHER 0x20
  std::uint16_t perm = 0;  // rwx bits 4, 2, 1
  std::uint32_t id = 0;    // uid or gid of ACL_USER / ACL_GROUP
};
/// The entries of a system.posix_acl_access attribute value; nullopt when it is not one (version 2).
std::optional<std::vector<AclEntry>> parse_posix_acl(const unsigned char* data, std::size_t size);

/// "" when a key file with this owner, mode (st_mode) and ACL (nullptr: none) may be used by a
/// process running as `euid`; else what is wrong, e.g. "mode 0640 gives group or others access".
std::string key_access_problem(uid_t owner, mode_t mode, const std::vector<AclEntry>* acl, uid_t euid);

}  // namespace pof::bus::auth
