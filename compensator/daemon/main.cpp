// pof-compensatord: subscribes to raw sample blocks, compensates every scan (Leal-Junior et al.
// 2017, eqs. (11)/(12)) and publishes the knee angle, per-cycle statistics and its own health.
//
//   POF_RAW[_ID] --> Pipeline --> POF_ANGLE[_ID], POF_STATS[_ID]; POF_COMPENSATOR_STATUS[_ID] at 1 Hz
//
// One thread: pof::bus::Receiver delivers blocks into the pipeline and the same loop publishes.
// Whatever arrives on the bus, the loop keeps turning: undecodable messages, malformed datagrams
// and duplicated or replayed blocks are counted in the status and logged rate-limited
// (docs/deployment.md, "Threat model"). With a bus key (--auth-key-file, or $POF_LCM_AUTH_KEY_FILE)
// it runs in the authenticated mode (pof/bus/auth.hpp): POF_RAW messages are verified before they
// are decoded (unsigned, forged, stale and replayed ones dropped and counted in the status) and
// everything it publishes is signed. The loop takes signals itself (pof::service::SignalWaiter)
// once per turn, at least every 100 ms: SIGTERM/SIGINT stop, SIGHUP reloads the calibration between
// blocks (a bad file keeps the old calibration, is counted and named in the status). Under systemd
// (Type=notify) the loop sends READY once subscribed and feeds the watchdog only while it keeps
// turning. Exit codes: pof::service::run_main (docs/deployment.md, "Exit codes and signals").
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "lcm_sink.hpp"
#include "pipeline.hpp"
#include "pof/bus/auth_key.hpp"
#include "pof/bus/channels.hpp"
#include "pof/bus/error_log.hpp"
#include "pof/bus/open.hpp"
#include "pof/bus/publisher.hpp"
#include "pof/bus/receiver.hpp"
#include "pof/bus/url.hpp"
#include "pof/io/calibration_file.hpp"
#include "pof/base/errors.hpp"
#include "pof/service/cli_checks.hpp"
#include "pof/service/run_main.hpp"
#include "pof/service/sd_notify.hpp"
#include "pof/service/signals.hpp"
#include "pof/lcm/utime.hpp"

namespace {

using pof::lcmutil::now_utime;

std::int64_t clamp_count(std::uint64_t n) {
  return static_cast<std::int64_t>(std::min<std::uint64_t>(n, std::numeric_limits<std::int64_t>::max()));
}

struct Options {
  std::string cal;
  std::string sensor_id;
  bool allow_other_sensor = false;
  std::string lcm_url;
  std::string pot_cal;
  std::string velocity_source = "sensor";
  std::string model = "file";
  double output_rate_hz = 0;
  double scan_rate_hz = 200;  // what the calibration's [gap] terms are checked at (blocks carry their own)
  double velocity_window_s = 0.5;
  double reversal_window_s = pof::core::CompensatorSettings{}.reversal_window_s;
  bool no_model_steps = false;
  std::string dynamic_angle = "estimate";
  double estimator_lag_ms = 0;
  int queue_capacity = 10000;
  double duration_s = 0;
  std::string auth_key_file;
  double auth_window_s = 2.0;
};

int run(const Options& o) {
  // Before liblcm or anything else may start a thread, so that every thread inherits the mask.
  const pof::service::SignalWaiter signals;

  pof::compensatord::PipelineSettings ps;
  ps.sensor_id = o.sensor_id;
  ps.allow_other_sensor = o.allow_other_sensor;
  ps.output_rate_hz = o.output_rate_hz;
  ps.compensator.scan_rate_hz = o.scan_rate_hz;
  ps.compensator.velocity_window_s = o.velocity_window_s;
  ps.compensator.reversal_window_s = o.reversal_window_s;
  ps.compensator.model_steps = !o.no_model_steps;
  ps.compensator.estimate = o.dynamic_angle == "estimate";
  ps.compensator.estimator_lag_s = o.estimator_lag_ms / 1000;
  ps.compensator.velocity_source =
      o.velocity_source == "reference" ? pof::core::VelocitySource::kReference : pof::core::VelocitySource::kSensor;
  std::optional<pof::core::PotentiometerCalibration> pot;
  if (!o.pot_cal.empty()) pot = pof::io::load_potentiometer(o.pot_cal);

  // A calibration with a [gap] term the compensator cannot apply is refused here (exit 78).
  pof::compensatord::Pipeline pipeline(pof::io::load_calibration(o.cal, o.model, o.scan_rate_hz), o.cal, ps, pot);
  const std::string key_file = pof::bus::auth::resolve_key_file(o.auth_key_file);
  const std::shared_ptr<const pof::bus::auth::Key> key =
      key_file.empty() ? nullptr : pof::bus::auth::load_key_file(key_file);  // ConfigError (78) naming the file

  const std::string url = pof::bus::resolve_url(o.lcm_url);
  lcm::LCM lc(url);
  pof::bus::require_usable(lc, url);
  pof::bus::Publisher pub(lc, key);
  using pof::bus::Stream;
  const std::string raw_ch = pof::bus::channel(Stream::kRaw, o.sensor_id);
  const std::string angle_ch = pof::bus::channel(Stream::kAngle, o.sensor_id);
  // Bad input and refused publishes are logged: the first of each kind in full, then a count every 10 s.
  pof::bus::ErrorLog errors([](const std::string& line) { spdlog::warn("{}", line); });
  pof::compensatord::LcmSink sink(pub, angle_ch, pof::bus::channel(Stream::kStats, o.sensor_id), errors);
  const pof::compensatord::LcmSink::Out status_out(pof::bus::channel(Stream::kCompensatorStatus, o.sensor_id));

  // The stream counts as quiet after kQuiet without blocks: the cycle in progress is closed then
  // (pof-daqd stopped or the cable is out), so a session's last cycle reaches POF_STATS.
  constexpr auto kQuiet = std::chrono::seconds(1);
  auto last_block = std::chrono::steady_clock::now();
  bool quiet = true;
  pof::bus::ReceiverOptions ro;
  ro.lcm_queue_capacity = o.queue_capacity;
  ro.auth_key = key;
  ro.auth.window_us = static_cast<std::uint64_t>(std::llround(o.auth_window_s * 1e6));
  pof::bus::Receiver rx(lc, url, ro);
  rx.subscribe<pof::raw_block_t>(raw_ch, [&](const pof::raw_block_t& b, const pof::bus::Delivery&) {
    pipeline.on_block(b, now_utime(), sink);  // noexcept
    last_block = std::chrono::steady_clock::now();
    quiet = false;
  });
  const std::string auth_errors_key = raw_ch + " (authentication)";  // rate-limited apart from decode errors
  rx.on_error([&](const pof::bus::ReceiveError& e) {
    errors.note(e.kind == pof::bus::ReceiveError::Kind::kAuth ? std::string_view(auth_errors_key) : e.channel,
                e.describe(), now_utime());
  });
  std::uint64_t malformed_seen = 0, incomplete_seen = 0;

  pof::service::ServiceNotifier notifier;
  notifier.ready("compensating " + raw_ch + " with " + o.cal);
  spdlog::info("{} -> {} on {} (calibration {}, output {})", raw_ch, angle_ch,
               url, o.cal, o.output_rate_hz > 0 ? std::to_string(o.output_rate_hz) + " Hz" : std::string("every scan"));
  if (key)
    spdlog::info("authenticated mode: bus key {} (key id {}), freshness window {} s; publishing as sender {:016x}",
                 key_file, pof::bus::auth::key_id_hex(key->id()), o.auth_window_s, pub.signer()->sender_id());

  std::int64_t status_seq = 0;
  auto next_status = std::chrono::steady_clock::now();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                              std::chrono::duration<double>(o.duration_s));
  while (o.duration_s <= 0 || std::chrono::steady_clock::now() < deadline) {
    if (rx.handle(100) < 0) ::usleep(100'000);  // a socket error: do not spin; counters and status go on

    const int sig = signals.wait(std::chrono::nanoseconds::zero());  // the 100 ms above bound the latency
    if (pof::service::SignalWaiter::is_stop(sig)) {
      spdlog::info("signal {}: stopping", sig);
      break;
    }
    if (sig == SIGHUP) {
      try {
        pipeline.replace_calibration(pof::io::load_calibration(o.cal, o.model, o.scan_rate_hz), o.cal);
        spdlog::info("reloaded calibration {}", o.cal);
      } catch (const std::exception& e) {
        pipeline.note_reload_failure(e.what());
        spdlog::error("calibration reload failed, keeping the previous one: {}", e.what());
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (!quiet && now - last_block >= kQuiet) {
      pipeline.finish(sink);
      quiet = true;
    }
    if (now >= next_status) {
      pof::compensator_status_t st = pipeline.status(now_utime());
      st.seq = status_seq++;
      const pof::bus::ReceiverStats rs = rx.stats();
      st.decode_errors = clamp_count(rs.decode_errors);
      st.malformed_datagrams = clamp_count(rs.malformed_datagrams + rs.incomplete_messages);
      st.authenticated = rs.authenticated;
      st.auth_unsigned = clamp_count(rs.auth_unsigned);
      st.auth_bad_mac = clamp_count(rs.auth_bad_mac);
      st.auth_stale = clamp_count(rs.auth_stale);
      st.auth_replayed = clamp_count(rs.auth_replayed);
      if (rs.malformed_datagrams > malformed_seen || rs.incomplete_messages > incomplete_seen)
        errors.note("(udpm)",
                    url + ": " + std::to_string(rs.malformed_datagrams - malformed_seen) +
                        " datagrams that are not LCM packets or carry impossible fragment headers, " +
                        std::to_string(rs.incomplete_messages - incomplete_seen) +
                        " fragmented messages abandoned incomplete (in the last second)",
                    now_utime());
      malformed_seen = rs.malformed_datagrams;
      incomplete_seen = rs.incomplete_messages;
      errors.tick(now_utime());
      if (!sink.sent(pub.publish(status_out.channel, st), status_out)) pipeline.note_publish_failure();  // in the next status
      next_status = now + std::chrono::seconds(1);
    }
    notifier.watchdog_if_due();
  }
  pipeline.finish(sink);
  notifier.stopping("stopping");
  const pof::compensator_status_t fin = pipeline.status(0);
  const pof::bus::ReceiverStats rs = rx.stats();
  spdlog::info("stopped: {} blocks, {} scans, {} lost scans, {} angles, {} cycles; {} duplicate blocks, {} decode "
               "errors, {} malformed datagrams, {} incomplete messages; {} publish failures",
               fin.blocks, fin.scans, fin.lost_scans, fin.angles, fin.cycles, fin.duplicate_blocks, rs.decode_errors,
               rs.malformed_datagrams, rs.incomplete_messages, fin.publish_failures);
  if (rs.authenticated)
    spdlog::info("authentication dropped: {} unsigned, {} bad MAC, {} stale, {} replayed", rs.auth_unsigned,
                 rs.auth_bad_mac, rs.auth_stale, rs.auth_replayed);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("pof-compensatord"));
  spdlog::set_pattern("pof-compensatord: %^%l%$: %v");
  CLI::App app{"pof-compensatord: compensates POF_RAW blocks into POF_ANGLE and POF_STATS"};
  app.set_version_flag("--version", POF_VERSION);
  Options o;
  app.add_option("--cal", o.cal, "Calibration file (TOML, from `pof calibrate`); SIGHUP reloads it")
      ->required();
  app.add_option("--sensor-id", o.sensor_id, "Sensor id suffixing every channel, e.g. LEFT_KNEE -> POF_RAW_LEFT_KNEE")
      ->check(pof::service::sensor_id());
  app.add_flag("--allow-other-sensor", o.allow_other_sensor,
               "Take a calibration whose sensor_id is another sensor's (refused otherwise: exit 78 at start, a counted "
               "reload failure on SIGHUP)");
  app.add_option("--lcm-url", o.lcm_url, "LCM URL (default: $LCM_DEFAULT_URL, else udpm on this host, ttl=0)");
  app.add_option("--pot-cal", o.pot_cal, "Potentiometer calibration (TOML) when blocks carry `pot` volts and the calibration has none");
  app.add_option("--velocity-source", o.velocity_source, "Where velocity and direction come from: sensor | reference")
      ->capture_default_str();
  app.add_option("--model", o.model, "Sensor model: file (the calibration's active_model), paper or dynamic")
      ->check(CLI::IsMember({"file", "paper", "dynamic"}))->capture_default_str();
  app.add_option("--output-rate", o.output_rate_hz, "Published angle rate [Hz] (boxcar decimation); 0 = every scan")
      ->check(pof::service::non_negative())->capture_default_str();
  app.add_option("--scan-rate", o.scan_rate_hz,
                 "Expected scan rate [Hz]: the calibration's [gap] terms are checked at it at start and on SIGHUP "
                 "(blocks carry their own rate; a block at a rate the terms cannot run at is rejected)")
      ->check(pof::service::positive())->capture_default_str();
  app.add_option("--velocity-window", o.velocity_window_s, "Velocity estimator window [s]")
      ->check(pof::service::positive())->capture_default_str();
  app.add_option("--reversal-window", o.reversal_window_s,
                 "Short window that detects reversals early [s] (0: direction from the velocity window alone)")
      ->check(CLI::Range(0.0, 10.0))->capture_default_str();
  app.add_flag("--no-model-steps", o.no_model_steps,
               "Paper model: do not read the start/stop/reversal steps eqs. (11)/(12) predict as changes of direction");
  app.add_option("--dynamic-angle", o.dynamic_angle,
                 "Dynamic model: estimate the angle (the calibration's [estimator]) or invert the model scan by scan")
      ->check(CLI::IsMember({"estimate", "invert"}))->capture_default_str();
  app.add_option("--estimator-lag", o.estimator_lag_ms,
                  "Estimator: publish each scan this late, its angle smoothed by the scans since [ms] (0: causal; "
                  "at most 256 scans; not with [gap] terms)")
      ->check(CLI::Range(0.0, 320.0))->capture_default_str();
  app.add_option("--duration", o.duration_s, "Stop after this many seconds (tests, benchmarks); 0 = until SIGTERM")
      ->check(pof::service::non_negative(pof::service::kMaxSeconds));
  app.add_option("--queue-capacity", o.queue_capacity, "LCM subscription queue [messages] (transports other than udpm://)")
      ->check(CLI::Range(1, 1000000))->capture_default_str();
  app.add_option("--auth-key-file", o.auth_key_file,
                 std::string("Bus key: verify POF_RAW and sign what is published (default: $") +
                     pof::bus::auth::kKeyFileEnv + ", else unauthenticated; docs/deployment.md)");
  app.add_option("--auth-window", o.auth_window_s,
                 "Authenticated mode: largest difference between a message's counter and this host's clock [s]")
      ->check(CLI::Range(0.001, 3600.0))->capture_default_str();
  return pof::service::run_main("pof-compensatord", app, argc, argv, [&] {
    if (o.velocity_source != "sensor" && o.velocity_source != "reference")
      throw CLI::ValidationError("--velocity-source", "expected 'sensor' or 'reference', got '" + o.velocity_source + "'");
    if (o.reversal_window_s > o.velocity_window_s)
      throw CLI::ValidationError("--reversal-window", "must not exceed --velocity-window (" +
                                 std::to_string(o.velocity_window_s) + " s)");
    return run(o);
  });
}
