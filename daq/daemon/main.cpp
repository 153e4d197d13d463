// pof-daqd: acquisition daemon. Reads the DAQ (USB-6008/6009 via libusb, USB-1208LS via hidapi, or
// the simulator), publishes POF_RAW blocks and POF_DAQ_STATUS on LCM. See docs/daq.md.
//
// Exit codes (pof/base/exit_codes.hpp, mapped by pof::service::run_main): 0 stopped on
// SIGTERM/SIGINT, --duration or the end of a finite sim:<scenario>, 2 usage, 66 --config file
// missing, 74 LCM unusable, 78 bad configuration (names the key). SIGHUP is logged and changes
// nothing: the configuration is read once (restart to apply a new one).
// USB errors are never fatal: the daemon reports them and recovers (docs/daq.md, "States").
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>

// GCC 12's -Wnull-dereference fires inside CLI11's inlined string splitting (a false positive in
// a system header that -isystem cannot silence, since the warning comes from the optimiser).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <CLI/CLI.hpp>
#pragma GCC diagnostic pop
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "pof/bus/auth_key.hpp"
#include "pof/bus/url.hpp"
#include "pof/daq/stream/backend.hpp"
#include "pof/daq/stream/config.hpp"
#include "daemon.hpp"
#include "pof/base/errors.hpp"
#include "pof/base/toml_reader.hpp"
#include "pof/daq/protocol/mcc_usb1208ls.hpp"
#include "pof/service/cli_checks.hpp"
#include "pof/service/run_main.hpp"
#include "pof/service/signals.hpp"

namespace {

constexpr const char* kDefaultConfig = "/etc/pof/daqd.toml";

}  // namespace

int main(int argc, char** argv) {
  using namespace pof;
  CLI::App app{
      "pof-daqd: acquisition daemon for the POF knee sensor. Streams raw blocks on POF_RAW and "
      "its health on POF_DAQ_STATUS (LCM).",
      "pof-daqd"};
  app.set_version_flag("--version", POF_VERSION);
  std::string config_path;
  std::string device;
  std::string serial;
  std::string lcm_url;
  std::string sensor_id;
  std::string auth_key_file;
  double rate = 0;
  int decimate = 0;
  int block_scans = 0;
  std::vector<std::string> sets;
  double duration_s = 0;
  bool print_config = false;
  bool probe = false;
  std::string log_level = "info";
  app.add_option("-c,--config", config_path,
                 std::string("TOML configuration (default ") + kDefaultConfig + " when present)");
  app.add_option("-d,--device", device, "device.kind: usb6008, usb6009, usb1208ls or sim:<scenario>");
  app.add_option("--serial", serial, "device.serial: the device to use when several are attached");
  // Given, each must be a value the configuration could hold: 0 here means "not given", so a 0 or a
  // negative one must be refused, never read as "use the configured value".
  app.add_option("-r,--rate", rate, "acquisition.scan_rate_hz")->check(pof::service::positive());
  app.add_option("--decimate", decimate, "acquisition.decimate")->check(CLI::Range(1, 1'000'000));
  app.add_option("--block-scans", block_scans, "acquisition.block_scans")->check(CLI::Range(1, 1'000'000));
  app.add_option("--lcm-url", lcm_url, "lcm.url (default: $LCM_DEFAULT_URL, else udpm on this host, ttl=0)");
  app.add_option("--sensor-id", sensor_id, "lcm.sensor_id (channel suffix)");
  app.add_option("--auth-key-file", auth_key_file,
                 std::string("lcm.auth_key_file: bus key, sign everything published (default: $") +
                     bus::auth::kKeyFileEnv + ", else unauthenticated; docs/deployment.md)");
  app.add_option("-s,--set", sets, "override any key: section.key=value (repeatable)");
  app.add_option("--duration", duration_s, "stop after this many seconds (tests, benchmarks)")
      ->check(pof::service::non_negative(pof::service::kMaxSeconds));
  app.add_flag("--print-config", print_config, "print the effective configuration and exit");
  app.add_flag("--probe", probe,
               "hardware bring-up: stream until the device's protocol variant is told (or --duration, "
               "default 5 s), print one line (state, scans, variant) on stdout; exit 0 if it "
               "streamed, 74 if not (docs/hardware-bringup.md)");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  return service::run_main("pof-daqd", app, argc, argv, [&]() -> int {
    auto logger = spdlog::stderr_color_mt("pof-daqd");
    spdlog::set_default_logger(logger);
    spdlog::set_level(spdlog::level::from_str(log_level));

    toml::table table;
    std::string source = "defaults";
    if (!config_path.empty()) {
      table = daq::read_config_file(config_path);
      source = config_path;
    } else if (std::filesystem::exists(kDefaultConfig)) {
      table = daq::read_config_file(kDefaultConfig);
      source = kDefaultConfig;
    } else {
      table.insert("schema_version", daq::kSchemaVersion);
    }
    // A key given both by its own option and by -s is a contradiction, whatever the two values:
    // refused (exit 2) rather than one of them silently winning.
    const std::pair<const char*, bool> given[] = {
        {"device.kind", !device.empty()},          {"device.serial", !serial.empty()},
        {"acquisition.scan_rate_hz", rate > 0},    {"acquisition.decimate", decimate > 0},
        {"acquisition.block_scans", block_scans > 0}, {"lcm.url", !lcm_url.empty()},
        {"lcm.sensor_id", !sensor_id.empty()},     {"lcm.auth_key_file", !auth_key_file.empty()}};
    for (const auto& s : sets)
      for (const auto& [path, set] : given)
        if (set && s.substr(0, s.find('=')) == path)  // the key as apply_toml_override reads it
          throw pof::UsageError("-s " + s + ": " + path + " is also given by its own option; give it once");
    // Options are typed values already: set as they are, never re-parsed as TOML text.
    if (!device.empty()) pof::set_toml_path(table, "device.kind", device);
    if (!serial.empty()) pof::set_toml_path(table, "device.serial", serial);
    if (rate > 0) pof::set_toml_path(table, "acquisition.scan_rate_hz", rate);
    if (decimate > 0) pof::set_toml_path(table, "acquisition.decimate", static_cast<std::int64_t>(decimate));
    if (block_scans > 0) pof::set_toml_path(table, "acquisition.block_scans", static_cast<std::int64_t>(block_scans));
    if (!lcm_url.empty()) pof::set_toml_path(table, "lcm.url", lcm_url);
    if (!sensor_id.empty()) pof::set_toml_path(table, "lcm.sensor_id", sensor_id);
    if (!auth_key_file.empty()) pof::set_toml_path(table, "lcm.auth_key_file", auth_key_file);
    for (const auto& s : sets) pof::apply_toml_override(table, s);
    if (!sets.empty() || !device.empty() || rate > 0 || decimate > 0 || block_scans > 0 ||
        !lcm_url.empty() || !sensor_id.empty() || !serial.empty() || !auth_key_file.empty()) {
      source += " + command line";
    }
    daq::DaqConfig cfg = daq::config_from_table(table, source);
    // --lcm-url, else lcm.url of the file, else $LCM_DEFAULT_URL, else this host only: the rule of
    // every pofkit process (pof/bus/url.hpp); --print-config shows the URL it resolved to.
    cfg.lcm_url = bus::resolve_url(cfg.lcm_url);
    // The bus key, by the same precedence: --auth-key-file, lcm.auth_key_file, $POF_LCM_AUTH_KEY_FILE
    // (pof/bus/auth_key.hpp); the Daemon reads and checks it.
    cfg.auth_key_file = bus::auth::resolve_key_file(cfg.auth_key_file);
    if (print_config) {
      std::cout << daq::to_toml(cfg);
      return pof::kExitOk;
    }

    // Before the backend and the daemon start their threads, so that they inherit the mask.
    const service::SignalWaiter signals;

    if (cfg.device_kind == "usb1208ls" && !cfg.mcc_single_reads &&
        daq::mcc::queue_length(cfg.channels().size()) != cfg.channels().size()) {
      spdlog::warn("usb1208ls: its channel queue holds 1, 2, 4 or 8 inputs: scanning {} for the {} "
                   "channels, the extra input's samples are dropped (docs/daq.md)",
                   daq::mcc::queue_length(cfg.channels().size()), cfg.channels().size());
    }
    daq::Daemon daemon(cfg, daq::make_backend(cfg));
    spdlog::info("{} at {} scans/s x {} channels, publishing {} and {} on {}", cfg.device_kind,
                 cfg.scan_rate_hz, cfg.channels().size(), cfg.raw_channel(), cfg.status_channel(),
                 cfg.lcm_url);
    daemon.start();
    if (probe && duration_s <= 0) duration_s = 5.0;
    const auto t0 = std::chrono::steady_clock::now();
    for (;;) {
      const int sig = signals.wait(std::chrono::milliseconds(200));
      if (service::SignalWaiter::is_stop(sig)) {
        spdlog::info("signal {}: stopping", sig);
        break;
      }
      if (sig == SIGHUP)
        spdlog::info("SIGHUP ignored: pof-daqd reads its configuration once (restart to apply a new one)");
      if (duration_s > 0 &&
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() >= duration_s) {
        break;
      }
      if (probe && daemon.variant_known()) break;
      if (daemon.finished()) {  // a finite simulated session is over: publish the final status, exit 0
        spdlog::info("source finished: stopping");
        break;
      }
    }
    if (probe) {
      const std::string line = daemon.probe_line();  // before stop(): the state the device reached
      const bool streamed = daemon.scans() > 0;
      daemon.stop();
      std::printf("pof-daqd probe: %s\n", line.c_str());
      std::fflush(stdout);
      return streamed ? pof::kExitOk : pof::kExitIoErr;
    }
    daemon.stop();
    return pof::kExitOk;
  });
}
