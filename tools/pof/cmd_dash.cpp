// `pof dash`: the live session in a browser (docs/dashboard.md). The model and
// the web server are pof_dash (tools/dash/); this file wires them to the bus.
// Two threads: this one poll()s the receiver's fd and the signal waiter's
// signalfd (as `pof spy` does) and feeds the model; the web server's thread
// builds each browser's frame from it. One mutex between them, held per message
// and per frame (microseconds), so the bus is drained at its own pace whatever
// the browsers do.
#include <poll.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "auth_options.hpp"
#include "commands.hpp"
#include "plot.hpp"
#include "pof/base/errors.hpp"
#include "pof/bus/open.hpp"
#include "pof/bus/receiver.hpp"
#include "pof/bus/udp_socket.hpp"
#include "pof/bus/url.hpp"
#include "pof/dash/model.hpp"
#include "pof/dash/server.hpp"
#include "pof/lcm/utime.hpp"
#include "pof/service/cli_checks.hpp"
#include "pof/service/signals.hpp"

namespace pof::cli {
namespace {

using pof::lcmutil::now_utime;

// Debian's libjs-chart.js (Chart.js 3): served from where the package puts it,
// never fetched.
constexpr const char* kDebianChartJs = "/usr/share/javascript/chart.js/chart.min.js";

struct DashArgs {
  std::string url;
  std::string listen = "127.0.0.1";
  int port = 8090;
  double window_s = 60;
  double display_hz = 100;
  double frame_hz = 20;
  double duration_s = 0;
  std::string chart_js = kDebianChartJs;
  int queue_capacity = 100000;
  AuthArgs auth;
};

// The page's files: web/ of pof_dash, found as the plot scripts are (plot.hpp),
// and Chart.js.
std::map<std::string, std::string> page_files(const DashArgs& a) {
  std::map<std::string, std::string> files;
  for (const char* f : {"index.html", "dash.js", "dash.css"}) {
    const std::string path = find_share_file("POF_DASH_DIR", POF_DASH_DIR_RELATIVE, POF_DASH_DIR_SOURCE, f);
    if (path.empty())
      throw pof::NoInputError(std::string(f) +
                              ": the dashboard's page is not installed (set "
                              "POF_DASH_DIR to tools/dash/web)");
    files[std::string("/") + (std::string(f) == "index.html" ? "" : f)] = path;
  }
  files["/index.html"] = files["/"];
  files["/chart.min.js"] = a.chart_js;
  return files;
}

void run_dash(const DashArgs& a) {
  service::SignalWaiter signals;  // before any thread: the web server's inherits the mask
  const Auth auth = load_auth(a.auth);
  const std::string url = bus::resolve_url(a.url);
  lcm::LCM lcm(url);
  bus::require_usable(lcm, url);

  dash::ModelSettings ms;
  ms.window_s = a.window_s;
  ms.display_hz = a.display_hz;
  dash::Model model(ms);
  std::mutex mu;

  bus::ReceiverOptions ro;
  ro.lcm_queue_capacity = a.queue_capacity;
  ro.auth_key = auth.key;  // authenticated mode: only verified messages reach the model
  ro.auth = auth.settings;
  bus::Receiver rx(lcm, url, ro);
  // Every POF stream but the raw blocks, of every sensor (docs/deployment.md,
  // "Processes and channels"): the angles carry the uncompensated and reference
  // angles the page draws.
  rx.subscribe_raw("POF_(ANGLE|STATS|DAQ_STATUS|COMPENSATOR_STATUS)(_[A-Z0-9_]+)?",
                   [&](const bus::Delivery& d, const unsigned char* data, std::size_t size) {
                     const std::lock_guard<std::mutex> lock(mu);
                     model.on_message(d.channel, data, size, d.recv_utime);
                   });

  dash::ServerOptions so;
  so.address = a.listen;
  so.port = static_cast<uint16_t>(a.port);
  so.frame_hz = a.frame_hz;
  so.files = page_files(a);
  dash::Server server(
      so,
      [&] {
        const std::lock_guard<std::mutex> lock(mu);
        model.tick(now_utime());
      },
      [&](dash::Cursor& c) {
        const std::lock_guard<std::mutex> lock(mu);
        return model.frame(c, now_utime()).dump();
      });
  server.start();
  const std::string host = a.listen == "0.0.0.0" ? "<this host's address>" : a.listen;
  std::printf("pof dash: http://%s:%u/ (listening on %s; %s)\n", host.c_str(), server.port(), a.listen.c_str(),
              url.c_str());
  std::fflush(stdout);

  const bus::UdpmUrl udpm = bus::parse_udpm_url(url);
  const uint16_t udp_port = udpm.ok() ? udpm.port : 0;
  const uint64_t drops0 = udp_port != 0 ? bus::udp_drops(udp_port) : 0;
  const auto t0 = std::chrono::steady_clock::now();
  auto next_health = t0;
  std::string last_error;
  for (;;) {
    const auto now = std::chrono::steady_clock::now();
    if (a.duration_s > 0 && std::chrono::duration<double>(now - t0).count() >= a.duration_s) break;
    if (now >= next_health) {  // the counters only this thread may read, for the
                               // health panel
      next_health = now + std::chrono::milliseconds(200);
      const bus::ReceiverStats rs = rx.stats();
      const dash::ServerStats ss = server.stats();
      dash::BusHealth h;
      h.url = url;
      h.authenticated = rs.authenticated;
      h.auth_dropped = rs.auth_unsigned + rs.auth_bad_mac + rs.auth_stale + rs.auth_replayed;
      h.malformed_datagrams = rs.malformed_datagrams;
      h.decode_errors = rs.decode_errors;
      h.kernel_drops = udp_port != 0 ? bus::udp_drops(udp_port) - drops0 : 0;
      h.clients = ss.clients;
      h.frames_sent = ss.frames_sent;
      h.frames_skipped = ss.frames_skipped;
      {
        const std::lock_guard<std::mutex> lock(mu);
        model.set_bus(h);
      }
      if (const std::string e = server.last_error(); !e.empty() && e != last_error) {
        std::fprintf(stderr, "pof dash: %s\n", e.c_str());
        last_error = e;
      }
    }
    pollfd fds[2] = {{rx.fd(), POLLIN, 0}, {signals.fd(), POLLIN, 0}};
    if (::poll(fds, 2, 100) < 0) continue;
    if ((fds[0].revents & POLLIN) != 0) {
      for (int i = 0; i < 64 && rx.handle(0) > 0; ++i) {
      }
    }
    if ((fds[1].revents & POLLIN) != 0 &&
        service::SignalWaiter::is_stop(signals.wait(std::chrono::nanoseconds::zero())))
      break;
  }
  server.stop();
  const dash::ServerStats ss = server.stats();
  std::printf("pof dash: stopped; %llu frames sent, %llu skipped for slow browsers\n",
              static_cast<unsigned long long>(ss.frames_sent), static_cast<unsigned long long>(ss.frames_skipped));
}

}  // namespace

void add_dash(CLI::App& app) {
  auto a = std::make_shared<DashArgs>();
  auto* cmd = app.add_subcommand("dash",
                                 "Live view in a browser: angle against reference and "
                                 "uncompensated, the loop, each cycle's statistics "
                                 "and the DAQ and compensator health of every sensor on the bus "
                                 "(read-only; docs/dashboard.md)");
  cmd->add_option("--lcm-url", a->url, std::string("LCM URL (default $LCM_DEFAULT_URL or ") + bus::kHostOnlyUrl + ")");
  cmd->add_option("--listen", a->listen,
                  "Address to serve on: 127.0.0.1 is this host only; 0.0.0.0 (or this "
                  "host's LAN address) lets "
                  "a tablet on the LAN connect, unauthenticated: see docs/dashboard.md")
      ->capture_default_str();
  cmd->add_option("--port", a->port, "TCP port (0: any free port, printed at start)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  cmd->add_option("--window", a->window_s, "History a browser can show [s]")
      ->check(CLI::Range(10.0, 600.0))
      ->capture_default_str();
  cmd->add_option("--display-rate", a->display_hz, "Chart points per second and sensor (angles are thinned to it)")
      ->check(CLI::Range(10.0, 500.0))
      ->capture_default_str();
  cmd->add_option("--frame-rate", a->frame_hz, "Updates sent to each browser per second")
      ->check(CLI::Range(1.0, 60.0))
      ->capture_default_str();
  cmd->add_option("--duration", a->duration_s, "Serve this long [s], then exit (default: until SIGINT/SIGTERM)")
      ->check(pof::service::positive(pof::service::kMaxSeconds));
  cmd->add_option("--chart-js", a->chart_js, "Chart.js 3 to serve (Debian's libjs-chart.js)")->capture_default_str();
  cmd->add_option("--queue-capacity", a->queue_capacity,
                  "LCM subscription queue [messages] (transports other than udpm://)")
      ->check(pof::service::positive())
      ->capture_default_str();
  add_auth_options(cmd, a->auth);
  cmd->callback([a] { run_dash(*a); });
}

}  // namespace pof::cli
