// pof-testpub: a small LCM publisher for the e2e tests of `pof record` and `pof spy`.
//
//   pof-testpub --lcm-url URL burst --channel POF_RAW --count N --rate R [--scans K]
//       N raw_block_t messages with seq 0..N-1, paced at R msg/s (busy-wait pacing: sleeping is too
//       coarse at 100k msg/s); prints "sent N in T s (R msg/s)".
//   pof-testpub --lcm-url URL session --duration S [--suffix _LEFT_KNEE]
//       a plausible live session: POF_RAW at 100 blocks/s (10 scans of sensor/reference/pot),
//       POF_ANGLE at 100 Hz following a 0..90 deg sine (angle_sigma_deg NaN), POF_STATS every 2 s,
//       POF_DAQ_STATUS at 1 Hz, and an unknown channel FOREIGN_TELEMETRY (not one of our types).
//   pof-testpub --lcm-url URL angles --rate R --duration S [--suffix _LEFT_KNEE]
//       POF_ANGLE at R msg/s (a 0..90 deg, 2 s sine; every 500th flagged QUALITY_GAP) and POF_STATS
//       once a second with values that differ per cycle (rmse_comp_deg = 0.01 * cycle, ...);
//       prints one JSON line: what was sent, the last angle's fields and every cycle's statistics,
//       for `pof dash`'s browser test to compare the page with.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>
#include <pof/angle_t.hpp>
#include <pof/lcm/utime.hpp>
#include <pof/cycle_stats_t.hpp>
#include <pof/daq_status_t.hpp>
#include <pof/raw_block_t.hpp>

namespace {

using pof::lcmutil::now_utime;

pof::raw_block_t make_block(int64_t seq, int32_t scans, const std::string& sensor_id) {
  pof::raw_block_t b;
  b.utime = now_utime();
  b.seq = seq;
  b.first_scan = seq * scans;
  b.scan_rate_hz = 1000.0;
  b.sensor_id = sensor_id;
  b.n_channels = 3;
  b.channel_names = {"sensor", "reference", "pot"};
  b.channel_units = {"V", "V", "V"};
  b.n_scans = scans;
  b.volts.assign(static_cast<std::size_t>(scans), std::vector<float>{4.0f, 4.35f, 1.5f});
  b.flags = pof::raw_block_t::FLAG_SIMULATED;
  b.publish_utime = now_utime();
  return b;
}

int publish_angles(lcm::LCM& lcm, double rate, double duration, const std::string& suffix) {
  const auto t0 = std::chrono::steady_clock::now();
  const double period_ns = 1e9 / rate;
  const auto n = static_cast<int64_t>(rate * duration);
  pof::angle_t a{};
  std::string cycles = "[";
  int32_t cycle = 0;
  for (int64_t k = 0; k < n; ++k) {
    const auto due = t0 + std::chrono::nanoseconds(static_cast<int64_t>(static_cast<double>(k) * period_ns));
    while (std::chrono::steady_clock::now() < due) {  // busy-wait: sleeping is too coarse at 3 kHz
    }
    const double t = static_cast<double>(k) / rate;
    const double ref = 45.0 - 45.0 * std::cos(M_PI * t);
    a.utime = a.publish_utime = now_utime();
    a.seq = k;
    a.scan_index = k;
    a.angle_ref_deg = static_cast<float>(ref);
    a.angle_deg = static_cast<float>(ref + 0.3 * std::sin(7.0 * t));
    a.angle_uncomp_deg = static_cast<float>(ref + 3.0 * std::sin(M_PI * t + 0.5));
    a.angle_sigma_deg = 0.05f;
    a.velocity_rad_s = static_cast<float>(45.0 * M_PI / 180.0 * M_PI * std::sin(M_PI * t));
    a.phase = pof::angle_t::PHASE_FLEXION;
    a.quality = k % 500 == 499 ? int32_t{pof::angle_t::QUALITY_GAP} : 0;
    lcm.publish("POF_ANGLE" + suffix, &a);
    if (k > 0 && k % static_cast<int64_t>(rate) == 0) {
      pof::cycle_stats_t c{};
      c.utime = now_utime();
      c.seq = cycle;
      c.cycle = ++cycle;
      c.start_utime = c.utime - 1'000'000;
      c.end_utime = c.utime;
      c.velocity_rad_s = 0.1f * static_cast<float>(cycle);
      c.rmse_comp_deg = 0.01f * static_cast<float>(cycle);
      c.rmse_uncomp_deg = 1.0f + 0.01f * static_cast<float>(cycle);
      c.hysteresis_comp_pct = 0.5f;
      c.hysteresis_uncomp_pct = 6.25f;
      c.max_error_deg = 0.125f * static_cast<float>(cycle);
      c.n_samples = static_cast<int32_t>(rate);
      lcm.publish("POF_STATS" + suffix, &c);
      char b[160];
      std::snprintf(b, sizeof b, "%s{\"cycle\":%d,\"rmse_comp_deg\":%.9g,\"max_error_deg\":%.9g}", cycle > 1 ? "," : "",
                    c.cycle, static_cast<double>(c.rmse_comp_deg), static_cast<double>(c.max_error_deg));
      cycles += b;
    }
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("{\"sent\":%lld,\"seconds\":%.3f,\"last\":{\"seq\":%lld,\"angle_deg\":%.9g,\"angle_ref_deg\":%.9g,"
              "\"angle_uncomp_deg\":%.9g},\"cycles\":%s]}\n",
              static_cast<long long>(n), secs, static_cast<long long>(a.seq), static_cast<double>(a.angle_deg),
              static_cast<double>(a.angle_ref_deg), static_cast<double>(a.angle_uncomp_deg), cycles.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"LCM test publisher for pofkit's e2e tests"};
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  app.add_option("--lcm-url", url);
  app.require_subcommand(1);
  std::string channel = "POF_RAW";
  int64_t count = 1000;
  double rate = 1000;
  int32_t scans = 10;
  auto* burst = app.add_subcommand("burst", "N raw blocks at R msg/s");
  burst->add_option("--channel", channel);
  burst->add_option("--count", count);
  burst->add_option("--rate", rate);
  burst->add_option("--scans", scans);
  double duration = 5;
  std::string suffix;
  auto* session = app.add_subcommand("session", "a plausible live session");
  session->add_option("--duration", duration);
  session->add_option("--suffix", suffix);
  double angle_rate = 3333;
  auto* angles = app.add_subcommand("angles", "angles at R msg/s and statistics once a second");
  angles->add_option("--rate", angle_rate);
  angles->add_option("--duration", duration);
  angles->add_option("--suffix", suffix);
  CLI11_PARSE(app, argc, argv);

  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "pof-testpub: cannot open LCM URL %s\n", url.c_str());
    return 1;
  }
  if (burst->parsed()) {
    const pof::raw_block_t proto = make_block(0, scans, "BURST");
    std::vector<uint8_t> buf(static_cast<std::size_t>(proto.getEncodedSize()));
    const auto t0 = std::chrono::steady_clock::now();
    const double period_ns = 1e9 / rate;
    pof::raw_block_t b = proto;
    for (int64_t i = 0; i < count; ++i) {
      const auto due = t0 + std::chrono::nanoseconds(static_cast<int64_t>(static_cast<double>(i) * period_ns));
      while (std::chrono::steady_clock::now() < due) {
      }
      b.seq = i;
      b.first_scan = i * scans;
      b.utime = b.publish_utime = now_utime();
      b.encode(buf.data(), 0, static_cast<int>(buf.size()));
      lcm.publish(channel, buf.data(), static_cast<unsigned>(buf.size()));
    }
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("sent %lld messages of %zu bytes in %.3f s (%.0f msg/s)\n", static_cast<long long>(count), buf.size(), t,
                static_cast<double>(count) / t);
    return 0;
  }

  if (angles->parsed()) return publish_angles(lcm, angle_rate, duration, suffix);

  // session
  const std::string sensor_id = suffix.empty() ? "" : suffix.substr(1);
  const auto t0 = std::chrono::steady_clock::now();
  int64_t k = 0;
  int64_t stats_seq = 0;
  int64_t status_seq = 0;
  int32_t cycle = 0;
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < duration) {
    const double t = static_cast<double>(k) * 0.01;
    const double ref = 45.0 - 45.0 * std::cos(2.0 * M_PI * t / 2.0);  // 0..90 deg, 2 s cycle
    pof::raw_block_t b = make_block(k, 10, sensor_id);
    for (auto& scan : b.volts) {
      scan[0] = static_cast<float>((198.67 - ref) / 45.6621);  // f5 of the paper, inverted
      scan[2] = static_cast<float>(ref / 30.0);
    }
    lcm.publish("POF_RAW" + suffix, &b);
    pof::angle_t a{};
    a.utime = a.publish_utime = now_utime();
    a.seq = k;
    a.scan_index = k * 10;
    a.angle_ref_deg = static_cast<float>(ref);
    a.angle_deg = static_cast<float>(ref + 0.4);
    a.angle_uncomp_deg = static_cast<float>(ref + 2.5);
    a.velocity_rad_s = static_cast<float>(45.0 * M_PI / 180.0 * M_PI * std::sin(M_PI * t));
    a.phase = a.velocity_rad_s > 0.05f ? pof::angle_t::PHASE_FLEXION
              : a.velocity_rad_s < -0.05f ? pof::angle_t::PHASE_EXTENSION
                                          : pof::angle_t::PHASE_HOLD;
    a.quality = k < 5 ? int32_t{pof::angle_t::QUALITY_SETTLING} : 0;
    a.angle_sigma_deg = std::nanf("");  // as with the paper's model: no estimator, no sigma
    lcm.publish("POF_ANGLE" + suffix, &a);
    if (k % 100 == 0) {
      pof::daq_status_t s{};
      s.utime = now_utime();
      s.seq = status_seq++;
      s.sensor_id = sensor_id;
      s.device_kind = "sim:testpub";
      s.state = pof::daq_status_t::STATE_STREAMING;
      s.state_text = "streaming";
      s.scan_rate_hz = 1000;
      s.n_channels = 3;
      s.scans = k * 10;
      s.blocks = k;
      lcm.publish("POF_DAQ_STATUS" + suffix, &s);
      const char foreign[] = "not a pofkit message";
      lcm.publish("FOREIGN_TELEMETRY", foreign, sizeof foreign);
    }
    if (k > 0 && k % 200 == 0) {
      pof::cycle_stats_t c{};
      c.utime = now_utime();
      c.seq = stats_seq++;
      c.cycle = ++cycle;
      c.velocity_rad_s = 1.2f;
      c.rmse_comp_deg = 1.1f;
      c.rmse_uncomp_deg = 3.4f;
      c.hysteresis_comp_pct = 2.0f;
      c.hysteresis_uncomp_pct = 7.5f;
      c.max_error_deg = 2.9f;
      c.n_samples = 2000;
      lcm.publish("POF_STATS" + suffix, &c);
    }
    ++k;
    std::this_thread::sleep_until(t0 + std::chrono::milliseconds(10 * k));
  }
  return 0;
}
