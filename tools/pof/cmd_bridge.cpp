// `pof bridge`: the POF_* channels as JSON over UDP, one object per datagram, for PlotJuggler's
// "UDP Server" streaming source (docs/export.md, "PlotJuggler": what PlotJuggler does with them,
// how to set it up). Each datagram is
//
//   {"timestamp": <the message's utime in s since the epoch>, "<CHANNEL>": {<field>: <number>, ...}}
//
// PlotJuggler's JSON parser takes a top-level numeric "timestamp" as the sample time when "use
// field as timestamp" is ticked, flattens nested objects to "<topic>/<CHANNEL>/<field>", skips
// null, and stops the whole UDP server on a datagram that is not JSON: so NaN (no reference angle,
// no sigma) is sent as null, never as a bare NaN, and text fields are left out.
//
// The bus comes first: the receiver is pof::bus::Receiver (as in `pof spy`), the socket is
// non-blocking and a send that fails (buffer full, nobody listening: ECONNREFUSED from the last
// datagram's ICMP) is counted, never waited on or retried. --max-rate thins each channel by its
// messages' own utime (an angle is sent when it is at least 1/rate after the last one sent), so a
// 3,333 Hz angle stream reaches PlotJuggler at ~200 Hz; what was thinned is counted per channel and
// printed on exit. Raw blocks only with --raw: one datagram per block, each DAQ channel's mean
// volts over the block's scans (a boxcar decimation to the block rate).
#include <arpa/inet.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "auth_options.hpp"
#include "commands.hpp"
#include "pof/angle_t.hpp"
#include "pof/base/errors.hpp"
#include "pof/bus/fingerprint.hpp"
#include "pof/bus/receiver.hpp"
#include "pof/bus/url.hpp"
#include "pof/compensator_status_t.hpp"
#include "pof/cycle_stats_t.hpp"
#include "pof/daq_status_t.hpp"
#include "pof/lcm/decode.hpp"
#include "pof/lcm/json.hpp"
#include "pof/raw_block_t.hpp"
#include "pof/service/cli_checks.hpp"
#include "pof/service/signals.hpp"

namespace pof::cli {
namespace {

struct BridgeArgs {
  std::string url;
  std::string channels = "POF_.*";
  std::string udp = "127.0.0.1:9870";
  double max_rate_hz = 200;
  bool raw = false;
  double duration_s = 0;
  AuthArgs auth;
};

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using lcmutil::json_number;

// The messages' numeric fields (pof/lcm/json.hpp), and an angle's age when it was published.
template <class Msg>
nlohmann::json fields(const Msg& m) {
  return lcmutil::json_fields(m);
}
template <>
nlohmann::json fields(const pof::angle_t& m) {
  nlohmann::json j = lcmutil::json_fields(m);
  j["latency_ms"] = json_number(double(m.publish_utime - m.utime) / 1000.0);
  return j;
}

// Each channel's mean volts over the block, by the block's channel names.
nlohmann::json fields(const pof::raw_block_t& m) {
  nlohmann::json j = {{"seq", m.seq}, {"first_scan", m.first_scan}, {"n_scans", m.n_scans}, {"flags", m.flags}};
  for (std::size_t c = 0; c < m.channel_names.size(); ++c) {
    double sum = 0;
    for (const auto& scan : m.volts) sum += c < scan.size() ? double(scan[c]) : kNaN;
    j[m.channel_names[c] + "_v"] = json_number(m.volts.empty() ? kNaN : sum / double(m.volts.size()));
  }
  return j;
}

// "HOST:PORT" (a name or an IPv4 address, a port 1-65535) as a socket address; UsageError naming
// the option otherwise.
sockaddr_in parse_destination(const std::string& text) {
  const auto colon = text.rfind(':');
  const auto bad = [&](const std::string& why) {
    return pof::UsageError("--udp '" + pof::excerpt(text) + "': " + why);
  };
  if (colon == std::string::npos || colon == 0) throw bad("expected HOST:PORT, e.g. 127.0.0.1:9870");
  const std::string host = text.substr(0, colon), port = text.substr(colon + 1);
  char* end = nullptr;
  const long p = port.empty() ? 0 : std::strtol(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || p < 1 || p > 65535) throw bad("expected a port 1-65535 after ':'");
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* res = nullptr;
  if (const int rc = ::getaddrinfo(host.c_str(), nullptr, &hints, &res); rc != 0 || res == nullptr)
    throw bad(std::string("cannot resolve host '") + pof::excerpt(host) + "': " + ::gai_strerror(rc));
  sockaddr_in addr{};
  std::memcpy(&addr, res->ai_addr, sizeof addr);
  ::freeaddrinfo(res);
  addr.sin_port = htons(static_cast<uint16_t>(p));
  return addr;
}

struct ChannelCounts {
  uint64_t received = 0, sent = 0, decimated = 0, send_failures = 0;
  bool started = false;
  int64_t next_utime = 0;  // the earliest utime the next datagram may carry, once started
};

class Bridge {
 public:
  Bridge(const sockaddr_in& dest, double max_rate_hz, bool raw)
      : period_us_(max_rate_hz > 0 ? static_cast<int64_t>(std::llround(1e6 / max_rate_hz)) : 0), raw_(raw) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw pof::IoError(std::string("UDP socket: ") + std::strerror(errno));
    // Connected: send() needs no address, and a refused datagram is reported on a later send
    // (counted) instead of silently.
    if (::connect(fd_, reinterpret_cast<const sockaddr*>(&dest), sizeof dest) != 0) {
      const int e = errno;
      ::close(fd_);
      throw pof::IoError(std::string("UDP connect: ") + std::strerror(e));
    }
  }
  ~Bridge() { ::close(fd_); }
  Bridge(const Bridge&) = delete;
  Bridge& operator=(const Bridge&) = delete;

  void on_message(std::string_view channel, const unsigned char* data, std::size_t size) {
    switch (bus::message_type_of(data, size)) {
      case bus::MessageType::kAngle: return forward(channel, data, size, angle_);
      case bus::MessageType::kCycleStats: return forward(channel, data, size, stats_);
      case bus::MessageType::kDaqStatus: return forward(channel, data, size, daq_);
      case bus::MessageType::kCompensatorStatus: return forward(channel, data, size, comp_);
      case bus::MessageType::kRawBlock:
        if (raw_) forward(channel, data, size, raw_block_);
        return;
      case bus::MessageType::kUnknown: ++foreign_; return;
    }
  }

  void print_summary(std::FILE* out) const {
    uint64_t sent = 0, decimated = 0, failures = 0;
    for (const auto& [name, c] : counts_) {
      std::fprintf(out, "pof bridge: %s: received %" PRIu64 ", sent %" PRIu64 ", decimated %" PRIu64
                   ", send failures %" PRIu64 "\n", name.c_str(), c.received, c.sent, c.decimated, c.send_failures);
      sent += c.sent;
      decimated += c.decimated;
      failures += c.send_failures;
    }
    std::fprintf(out, "pof bridge: total: sent %" PRIu64 ", decimated %" PRIu64 ", send failures %" PRIu64
                 ", undecodable %" PRIu64 ", not pofkit's %" PRIu64 "\n", sent, decimated, failures, undecodable_,
                 foreign_);
  }

 private:
  template <class Msg>
  void forward(std::string_view channel, const unsigned char* data, std::size_t size, Msg& m) {
    if (!lcmutil::decode(data, size, m)) {
      ++undecodable_;
      return;
    }
    auto it = counts_.find(channel);
    if (it == counts_.end()) it = counts_.emplace(std::string(channel), ChannelCounts{}).first;
    ChannelCounts& c = it->second;
    ++c.received;
    if (period_us_ > 0 && c.started && m.utime < c.next_utime && m.utime > c.next_utime - 2 * period_us_) {
      ++c.decimated;
      return;
    }
    // (A utime far behind the last one sent, a restarted publisher, starts the thinning afresh.)
    c.started = true;
    c.next_utime = m.utime + period_us_;
    nlohmann::json j;
    j["timestamp"] = double(m.utime) * 1e-6;
    j[std::string(channel)] = fields(m);
    const std::string text = j.dump();
    if (::send(fd_, text.data(), text.size(), MSG_DONTWAIT | MSG_NOSIGNAL) == static_cast<ssize_t>(text.size())) {
      ++c.sent;
    } else {
      ++c.send_failures;
    }
  }

  int fd_ = -1;
  int64_t period_us_;
  bool raw_;
  std::map<std::string, ChannelCounts, std::less<>> counts_;
  uint64_t undecodable_ = 0, foreign_ = 0;
  // Decoded messages, reused (a raw block's vectors are not reallocated per message).
  pof::angle_t angle_{};
  pof::cycle_stats_t stats_{};
  pof::daq_status_t daq_{};
  pof::compensator_status_t comp_{};
  pof::raw_block_t raw_block_{};
};

void run_bridge(const BridgeArgs& a) {
  service::SignalWaiter signals;  // before any thread: every thread inherits the mask
  const Auth auth = load_auth(a.auth);
  const sockaddr_in dest = parse_destination(a.udp);
  const std::string url = bus::resolve_url(a.url);
  Bridge bridge(dest, a.max_rate_hz, a.raw);
  bus::ReceiverOptions ro;
  ro.auth_key = auth.key;
  ro.auth = auth.settings;
  bus::Receiver rx(url, ro);
  rx.subscribe_raw(a.channels, [&bridge](const bus::Delivery& d, const unsigned char* data, std::size_t size) {
    bridge.on_message(d.channel, data, size);
  });
  char where[INET_ADDRSTRLEN] = "?";
  ::inet_ntop(AF_INET, &dest.sin_addr, where, sizeof where);
  char rate[48] = "every message";
  if (a.max_rate_hz > 0) std::snprintf(rate, sizeof rate, "at most %g Hz per channel", a.max_rate_hz);
  std::fprintf(stderr, "pof bridge: %s (channels '%s') -> udp %s:%u, %s%s\n", url.c_str(), a.channels.c_str(), where,
               unsigned(ntohs(dest.sin_port)), rate, a.raw ? ", raw blocks as block means" : "");
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    int wait_ms = 1000;
    if (a.duration_s > 0) {
      const double left = a.duration_s - std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (left <= 0) break;
      wait_ms = static_cast<int>(std::min(1000.0, left * 1000.0)) + 1;
    }
    pollfd fds[2] = {{rx.fd(), POLLIN, 0}, {signals.fd(), POLLIN, 0}};
    if (::poll(fds, 2, wait_ms) < 0) continue;
    if ((fds[1].revents & POLLIN) != 0 && signals.wait(std::chrono::nanoseconds::zero()) != 0) break;
    if ((fds[0].revents & POLLIN) != 0) rx.handle(0);
  }
  bridge.print_summary(stderr);
  const bus::ReceiverStats rs = rx.stats();
  if (rs.malformed_datagrams + rs.incomplete_messages + rs.auth_unsigned + rs.auth_bad_mac + rs.auth_stale +
          rs.auth_replayed > 0) {
    std::fprintf(stderr, "pof bridge: bus: malformed datagrams %" PRIu64 ", incomplete messages %" PRIu64
                 ", dropped by the verifier %" PRIu64 "\n", rs.malformed_datagrams, rs.incomplete_messages,
                 rs.auth_unsigned + rs.auth_bad_mac + rs.auth_stale + rs.auth_replayed);
  }
}

}  // namespace

void add_bridge(CLI::App& app) {
  auto a = std::make_shared<BridgeArgs>();
  auto* cmd = app.add_subcommand("bridge",
                                 "Forward the POF_* channels as JSON datagrams over UDP (PlotJuggler's UDP Server, "
                                 "docs/export.md), thinned to --max-rate per channel");
  cmd->add_option("--lcm-url", a->url, std::string("LCM URL (default $LCM_DEFAULT_URL or ") + bus::kHostOnlyUrl + ")");
  cmd->add_option("-c,--channels", a->channels, "Regex of the channels to forward")->capture_default_str();
  cmd->add_option("--udp", a->udp, "Where to send the datagrams, HOST:PORT")->capture_default_str();
  cmd->add_option("--max-rate", a->max_rate_hz, "Most datagrams per second per channel, by message time (0: all)")
      ->check(CLI::Range(0.0, 1e6))
      ->capture_default_str();
  cmd->add_flag("--raw", a->raw, "Forward raw blocks too: each DAQ channel's mean volts per block");
  cmd->add_option("--duration", a->duration_s, "Stop after this long [s] (default: until SIGINT/SIGTERM)")
      ->check(pof::service::positive(pof::service::kMaxSeconds));
  add_auth_options(cmd, a->auth);
  cmd->callback([a] { run_bridge(*a); });
}

}  // namespace pof::cli
