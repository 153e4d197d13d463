#pragma once
// The one place where a pofkit binary turns an exception into its exit code and stderr line.
//
//   int main(int argc, char** argv) {
//     CLI::App app{"..."};
//     ... options ...
//     return pof::service::run_main("pof-daqd", app, argc, argv, [&] { ...; return pof::kExitOk; });
//   }
//
// The table (codes from pof/base/exit_codes.hpp; the message is "<program>: error: <what>"):
//
//   CLI::ParseError (from app.parse or thrown after it)   CLI11 prints it (--help, --version: exit 0);
//                                                          every other parse error exits 2
//   pof::Error and its subclasses                          the code it carries (UsageError 2, DataError 65,
//                                                          NoInputError 66, IoError 74, ConfigError 78)
//   std::invalid_argument, std::out_of_range               78: a value the configuration or command line
//                                                          gave that a constructor rejected (e.g. the
//                                                          compensator's settings, pof/core/compensator.hpp)
//   std::bad_alloc                                         74 "out of memory (std::bad_alloc)"
//   std::system_error (std::ios_base::failure,
//     std::filesystem::filesystem_error)                   74
//   any other exception                                    74 "internal error: <what>" (a bug: the code
//                                                          that found the problem should have thrown a
//                                                          pof::Error naming the file, key or device)
//
// docs/deployment.md, "Exit codes", is this table for users; the systemd units rely on 2 and 78
// (RestartPreventExitStatus=2 78: restarting cannot fix a bad command line or configuration).
#include <functional>
#include <string_view>

namespace CLI {
class App;
}  // namespace CLI

namespace pof::service {

/// Runs `body` and returns its result; an exception escaping it is printed on stderr as
/// "<program>: error: <what>" and mapped to an exit code by the table above.
int run_main(std::string_view program, const std::function<int()>& body);

/// Parses the command line with `app` (subcommand callbacks run inside the parse, so their
/// exceptions go through the table too), then runs `body` (validation of option combinations may
/// throw CLI::ValidationError there, and is reported by CLI11 like a parse error: exit 2).
int run_main(std::string_view program, CLI::App& app, int argc, const char* const* argv,
             const std::function<int()>& body);

}  // namespace pof::service
