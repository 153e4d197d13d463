// pof-angle-client: what a controller does with pofkit's output, in one file.
//
// Subscribes to POF_ANGLE[_<SENSOR_ID>] (pof::angle_t) and, per message:
//   - checks the sequence number: a jump of seq means angles were lost on the bus;
//   - reads the quality flags: an angle with QUALITY_INVALID_INPUT is NaN and must not be used,
//     the other flags say how far to trust it (see angle_t.lcm);
//   - measures the sample age: receive time minus angle_t.utime, the host time of the scan the
//     angle was computed from. That is what a control loop sees as measurement delay (the
//     pipeline's lag; the model's own filter lag comes on top, docs/controller.md, "Latency").
// Prints one line per second and a summary; exits 0 once --count angles have arrived, 1 on timeout.
//
// Authenticated mode (docs/deployment.md, "Authenticated mode"): with a key file, --key-file or
// else $POF_LCM_AUTH_KEY_FILE as for pofkit's own processes (pof::bus::auth::resolve_key_file; the
// bus key as `pof keygen` writes it, refused, exit 78, unless only its owner may read it), every message is
// verified before it is decoded, by the verifier pofkit's own receivers use (pofkit::auth), and
// one that is not is dropped and counted per verdict (unsigned, bad_mac, stale, replayed) in the
// summary. Without it nothing is verified: a forged POF_ANGLE is taken like pofkit's.
//
// Robustness, as in pof-compensatord: messages are decoded here, not by a typed subscription, so a
// malformed datagram on the bus is counted and skipped instead of ending the controller.
#include <lcm/lcm-cpp.hpp>
#include <poll.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "pof/angle_t.hpp"
#include "pof/bus/auth.hpp"      // the verifier of the authenticated mode (pofkit::auth)
#include "pof/bus/auth_key.hpp"  // the bus key file and its permission checks
#include "pof/bus/channels.hpp"  // pofkit's channel names
#include "pof/bus/url.hpp"       // the LCM URL rule every pofkit process follows
#include "pof/lcm/utime.hpp"     // microseconds since the epoch, the utime convention

namespace {

struct Stats {
  std::int64_t angles = 0, lost = 0, undecodable = 0, unusable = 0, flagged = 0;
  std::int64_t last_seq = -1;
  std::vector<double> age_ms;
  std::unique_ptr<pof::bus::auth::Verifier> verifier;  // with --key-file; it counts the drops
};

void on_message(const lcm::ReceiveBuffer* rbuf, const std::string& channel, Stats* s) {
  std::size_t size = rbuf->data_size;
  if (s->verifier) {
    // Before decoding: a forged message is not even parsed. The counter is compared with this
    // host's realtime clock, so sender and controller need synchronised clocks (chrony, PTP).
    const auto v = s->verifier->verify(channel, static_cast<const unsigned char*>(rbuf->data), size,
                                       pof::bus::auth::counter_time(pof::lcmutil::now_utime()));
    if (!v.ok()) return;  // counted by the verifier, per verdict
    size = v.message_size;  // the LCM message in front of the trailer
  }
  pof::angle_t m;
  if (size > INT32_MAX || m.decode(rbuf->data, 0, static_cast<int>(size)) < 0) {
    ++s->undecodable;
    return;
  }
  const std::int64_t now = pof::lcmutil::now_utime();
  if (s->last_seq >= 0 && m.seq > s->last_seq + 1) s->lost += m.seq - s->last_seq - 1;
  if (s->last_seq >= 0 && m.seq <= s->last_seq && m.seq != 0) return;  // duplicate or reordered
  s->last_seq = m.seq;
  ++s->angles;
  if ((m.quality & pof::angle_t::QUALITY_INVALID_INPUT) != 0 || !std::isfinite(m.angle_deg)) ++s->unusable;
  else if (m.quality != 0) ++s->flagged;
  s->age_ms.push_back(static_cast<double>(now - m.utime) / 1000.0);
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  const auto k = static_cast<std::size_t>(p / 100.0 * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

int usage(const char* argv0) {
  std::fprintf(stderr, "usage: %s [--lcm-url URL] [--sensor-id ID] [--count N] [--timeout S] [--key-file PATH (default $POF_LCM_AUTH_KEY_FILE)]\n",
               argv0);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string url_opt, sensor_id, key_file;
  long count = 200;
  double timeout_s = 30;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      usage(argv[0]);
      return 0;
    }
    if (i + 1 >= argc) return usage(argv[0]);
    const char* v = argv[++i];
    if (a == "--lcm-url") url_opt = v;
    else if (a == "--sensor-id") sensor_id = v;
    else if (a == "--count") count = std::strtol(v, nullptr, 10);
    else if (a == "--timeout") timeout_s = std::strtod(v, nullptr);
    else if (a == "--key-file") key_file = v;
    else return usage(argv[0]);
  }
  const std::string url = pof::bus::resolve_url(url_opt);
  const std::string channel = pof::bus::channel(pof::bus::Stream::kAngle, sensor_id);
  lcm::LCM lc(url);
  if (!lc.good()) {
    std::fprintf(stderr, "pof-angle-client: cannot open LCM URL %s\n", url.c_str());
    return 1;
  }
  Stats s;
  if (const std::string key = pof::bus::auth::resolve_key_file(key_file); !key.empty()) {
    try {
      s.verifier = std::make_unique<pof::bus::auth::Verifier>(pof::bus::auth::load_key_file(key));
    } catch (const std::exception& e) {  // pof::ConfigError: names the file and what is wrong with it
      std::fprintf(stderr, "pof-angle-client: %s\n", e.what());
      return 78;
    }
  }
  lcm::Subscription* sub = lc.subscribeFunction(channel, &on_message, &s);
  sub->setQueueCapacity(10000);  // LCM's default of 30 drops silently at 200 Hz under load
  const std::string verifying =
      s.verifier ? ", verifying with key id " + pof::bus::auth::key_id_hex(s.verifier->key_id()) : "";
  std::printf("listening on %s (%s)%s\n", channel.c_str(), url.c_str(), verifying.c_str());

  const auto t0 = std::chrono::steady_clock::now();
  auto next_line = t0 + std::chrono::seconds(1);
  while (s.angles < count) {
    const auto now = std::chrono::steady_clock::now();
    if (std::chrono::duration<double>(now - t0).count() > timeout_s) break;
    pollfd p{lc.getFileno(), POLLIN, 0};
    if (::poll(&p, 1, 100) > 0) lc.handle();
    if (now >= next_line) {
      std::printf("%lld angles, %lld lost, age p50 %.2f ms\n", static_cast<long long>(s.angles),
                  static_cast<long long>(s.lost), percentile(s.age_ms, 50));
      std::fflush(stdout);
      next_line += std::chrono::seconds(1);
    }
  }
  std::printf("summary: angles=%lld lost=%lld undecodable=%lld unusable=%lld flagged=%lld "
              "age_p50_ms=%.3f age_p99_ms=%.3f age_max_ms=%.3f",
              static_cast<long long>(s.angles), static_cast<long long>(s.lost),
              static_cast<long long>(s.undecodable), static_cast<long long>(s.unusable),
              static_cast<long long>(s.flagged), percentile(s.age_ms, 50), percentile(s.age_ms, 99),
              s.age_ms.empty() ? NAN : *std::max_element(s.age_ms.begin(), s.age_ms.end()));
  if (s.verifier) {  // what the authenticated mode dropped, per verdict: dropped_bad_mac=2 ...
    for (const auto v : pof::bus::auth::kDropVerdicts) {
      std::printf(" dropped_%s=%llu", pof::bus::auth::verdict_name(v),
                  static_cast<unsigned long long>(s.verifier->count(v)));
    }
  }
  std::printf("\n");
  return s.angles >= count ? 0 : 1;
}
