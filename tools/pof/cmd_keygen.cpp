// `pof keygen -o FILE`: a new bus key for the authenticated mode (docs/deployment.md,
// "Authenticated mode"): 32 random bytes (libsodium's randombytes_buf) as 64 hex digits and a line
// end, written atomically with mode 0600 (owner only) and never over an existing file, so a key in
// use is not replaced by accident. The owner is whoever runs it: root for /etc/pof/lcm.key (read by
// systemd's LoadCredential=, or chown'ed to the service user).
#include <sys/stat.h>

#include <cstdio>
#include <memory>
#include <string>

#include "commands.hpp"
#include "pof/bus/auth_key.hpp"
#include "pof/io/atomic_file.hpp"

namespace pof::cli {
namespace {

void run_keygen(const std::string& out) {
  std::string text = bus::auth::new_key_text();
  struct Wipe {
    std::string& s;
    ~Wipe() { bus::auth::wipe(s); }
  } wipe{text};
  io::write_file_atomic(out, text, 0600, io::Replace::kNo);  // IoError (74) when it exists
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
