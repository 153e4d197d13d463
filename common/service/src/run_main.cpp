#include "pof/service/run_main.hpp"

#include <cstdio>
#include <exception>
#include <new>
#include <stdexcept>
#include <string>
#include <system_error>

#include <CLI/CLI.hpp>

#include "pof/base/errors.hpp"
#include "pof/base/exit_codes.hpp"

namespace pof::service {

namespace {

void print_error(std::string_view program, std::string_view what) {
  // One write: lines of several processes sharing a journal or a test's stderr do not interleave.
  const std::string line = std::string(program) + ": error: " + std::string(what) + "\n";
  std::fputs(line.c_str(), stderr);
  std::fflush(stderr);
}

}  // namespace

int run_main(std::string_view program, const std::function<int()>& body) {
  try {
    return body();
  } catch (const pof::Error& e) {
    print_error(program, e.what());
    return e.code();
  } catch (const CLI::ParseError& e) {
    // Thrown without an App to report it (run_main(program, app, ...) lets CLI11 print it): a
    // usage error is still 2; CLI11's "success" exceptions (help, version) have nothing to report.
    if (e.get_exit_code() == 0) return kExitOk;
    print_error(program, e.what());
    return kExitUsage;
  } catch (const std::invalid_argument& e) {
    print_error(program, e.what());
    return kExitConfig;
  } catch (const std::out_of_range& e) {
    print_error(program, e.what());
    return kExitConfig;
  } catch (const std::bad_alloc& e) {
    print_error(program, std::string("out of memory (") + e.what() + ")");
    return kExitIoErr;
  } catch (const std::system_error& e) {
    print_error(program, e.what());
    return kExitIoErr;
  } catch (const std::exception& e) {
    print_error(program, std::string("internal error: ") + e.what());
    return kExitIoErr;
  } catch (...) {
    print_error(program, "internal error: an exception that is not a std::exception");
    return kExitIoErr;
  }
}

int run_main(std::string_view program, CLI::App& app, int argc, const char* const* argv,
             const std::function<int()>& body) {
  return run_main(program, [&]() -> int {
    try {
      app.parse(argc, argv);
      return body();
    } catch (const CLI::ParseError& e) {
      // CLI11 prints help, --version or the parse error itself; its own codes for usage errors
      // vary (105, 106, ...), pofkit's is 2 (pof/base/exit_codes.hpp).
      return app.exit(e) == 0 ? kExitOk : kExitUsage;
    }
  });
}

}  // namespace pof::service
