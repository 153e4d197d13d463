// `pof keygen -o FILE`: a new bus key for the authenticated mode (docs/deployment.md,
// "Authenticated mode"): 32 random bytes (libsodium's randombytes_buf) as 64 hex digits and a line
// end, written atomically with mode 0600 (owner only) and never over an existing file, so a key in
// use is not replaced by accident. The owner is whoever runs it: root for /etc/pof/lcm.key (read by
// systemd's LoadCredential=; the services' own copy is installed from it, docs/deployment.md).
#include <sys/stat.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.hpp"
#include "pof/base/errors.hpp"
#include "pof/bus/auth_key.hpp"
#include "pof/io/atomic_file.hpp"

namespace pof::cli {
namespace {

void run_keygen(const std::string& out) {
  // An existing -o is the caller's mistake, not an I/O failure: refused before a key is made, as a
  // usage error (2). A file (or dangling symlink) appearing after this check is still never
  // replaced: the no-replace write below refuses it (74).
  std::error_code ec;
  if (std::filesystem::symlink_status(out, ec).type() != std::filesystem::file_type::not_found && !ec)
    throw UsageError(out + ": exists; pof keygen never overwrites a key (remove it first, or choose another -o)");
  std::string text = bus::auth::new_key_text();
  struct Wipe {
    std::string& s;
    ~Wipe() { bus::auth::wipe(s); }
  } wipe{text};
  io::write_file_atomic(out, text, 0600, io::Replace::kNo);  // IoError (74) on a race with another writer
  // What was written is what a process will read: check it the same way (owner, mode, format).
  const auto key = bus::auth::load_key_file(out);
  std::printf("%s: new bus key, key id %s, mode 0600; docs/deployment.md, \"Authenticated mode\", says how to "
              "install it\n",
              out.c_str(), bus::auth::key_id_hex(key->id()).c_str());
}

}  // namespace

void add_keygen(CLI::App& app) {
  auto out = std::make_shared<std::string>();
  auto* cmd = app.add_subcommand("keygen",
                                 "Write a new bus key for the authenticated LCM mode (32 random bytes as hex, mode "
                                 "0600; an existing file is never overwritten)");
  cmd->add_option("-o,--output", *out, "Key file to create")->required();
  cmd->callback([out] { run_keygen(*out); });
}

}  // namespace pof::cli
