#pragma once
// The authenticated-mode options `pof spy` and `pof record` share (docs/deployment.md,
// "Authenticated mode"): --auth-key-file (default $POF_LCM_AUTH_KEY_FILE, the rule of
// pof/bus/auth_key.hpp) and --auth-window. With a key they verify every message and drop, and
// count, what fails; without one they take the bus as it is.
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "pof/bus/auth.hpp"
#include "pof/bus/auth_key.hpp"

namespace pof::cli {

struct AuthArgs {
  std::string key_file;
  double window_s = 2.0;
};

inline void add_auth_options(CLI::App* cmd, AuthArgs& a) {
  cmd->add_option("--auth-key-file", a.key_file,
                  std::string("Bus key: verify every message, drop and count what fails (default: $") +
                      bus::auth::kKeyFileEnv + ", else no verification; docs/deployment.md)");
  cmd->add_option("--auth-window", a.window_s,
                  "With a bus key: largest difference between a message's counter and this host's clock [s]")
      ->check(CLI::Range(0.001, 3600.0))
      ->capture_default_str();
}

/// The key the options name (null when none: unauthenticated) and the verifier's settings.
/// Throws ConfigError (78) naming a key file that cannot be used.
struct Auth {
  std::string key_file;
  std::shared_ptr<const bus::auth::Key> key;
  bus::auth::VerifierSettings settings;
};
inline Auth load_auth(const AuthArgs& a) {
  Auth out;
  out.key_file = bus::auth::resolve_key_file(a.key_file);
  if (!out.key_file.empty()) out.key = bus::auth::load_key_file(out.key_file);
  out.settings.window_us = static_cast<std::uint64_t>(std::llround(a.window_s * 1e6));
  return out;
}

}  // namespace pof::cli
