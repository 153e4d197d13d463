// `pof spy`: a terminal live view of the LCM bus (plain ANSI, works over SSH, no Java). The model
// and renderer are pof_spy (tools/spy/); this file is the loop: one thread poll()s the receiver's fd
// (pof::bus::Receiver: bounded, total, counts malformed datagrams), stdin and the signal waiter's
// signalfd, so there is no locking and 'q', SIGINT or SIGTERM quit at once; so does SIGHUP (the
// terminal hung up), which restores the terminal on the way out like the others.
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "auth_options.hpp"
#include "commands.hpp"
#include "pof/bus/open.hpp"
#include "pof/bus/receiver.hpp"
#include "pof/bus/udp_socket.hpp"
#include "pof/bus/url.hpp"
#include "pof/base/errors.hpp"
#include "pof/lcm/utime.hpp"
#include "pof/service/cli_checks.hpp"
#include "pof/service/signals.hpp"
#include "pof/spy/monitor.hpp"

namespace pof::cli {
namespace {

using pof::lcmutil::now_utime;

struct SpyArgs {
  std::string url;
  std::string channels = ".*";
  double refresh_hz = 4;
  double duration_s = 0;
  bool once = false;
  int queue_capacity = 100000;
  AuthArgs auth;
};

// Raw keyboard input while the view runs; restored on every exit path (RAII).
class RawTerminal {
 public:
  RawTerminal() {
    if (::isatty(STDIN_FILENO) == 0 || ::tcgetattr(STDIN_FILENO, &saved_) != 0) return;
    termios raw = saved_;
    raw.c_lflag &= ~static_cast<tcflag_t>(ICANON | ECHO);
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    active_ = ::tcsetattr(STDIN_FILENO, TCSANOW, &raw) == 0;
    std::fputs("\x1b[?25l", stdout);  // hide the cursor
  }
  ~RawTerminal() {
    if (!active_) return;
    ::tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
    std::fputs("\x1b[?25h", stdout);
    std::fflush(stdout);
  }
  RawTerminal(const RawTerminal&) = delete;
  RawTerminal& operator=(const RawTerminal&) = delete;
  [[nodiscard]] bool active() const { return active_; }

 private:
  termios saved_{};
  bool active_ = false;
};

int terminal_width() {
  winsize ws{};
  if (::ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) return ws.ws_col;
  return 100;
}

void run_spy(const SpyArgs& a) {
  service::SignalWaiter signals;  // before liblcm may start a thread: every thread inherits the mask
  const Auth auth = load_auth(a.auth);  // a bad key file: exit 78 before anything is shown
  const std::string url = bus::resolve_url(a.url);
  lcm::LCM lcm(url);
  bus::require_usable(lcm, url);
  spy::Monitor monitor;
  bus::ReceiverOptions ro;
  ro.lcm_queue_capacity = a.queue_capacity;
  ro.auth_key = auth.key;
  ro.auth = auth.settings;
  bus::Receiver rx(lcm, url, ro);
  rx.subscribe_raw(a.channels, [&monitor](const bus::Delivery& d, const unsigned char* data, std::size_t size) {
    monitor.on_message(d.channel, data, size, d.recv_utime);
  });
  const bus::UdpmUrl udpm = bus::parse_udpm_url(url);
  const uint16_t port = udpm.ok() ? udpm.port : 0;  // 0: not udpm (no kernel drop count)
  const uint64_t drops0 = port != 0 ? bus::udp_drops(port) : 0;

  const int sfd = signals.fd();

  const bool snapshot = a.once || a.duration_s > 0;
  // A snapshot collects for --duration (default 1 s for --once) and prints plain text once.
  const double collect_s = a.duration_s > 0 ? a.duration_s : 1.0;
  std::unique_ptr<RawTerminal> term;
  if (!snapshot) term = std::make_unique<RawTerminal>();

  const auto t0 = std::chrono::steady_clock::now();
  const auto period = std::chrono::duration<double>(1.0 / a.refresh_hz);
  auto next_frame = t0;
  const int rx_fd = rx.fd();
  bool quit = false;
  auto draw = [&](bool ansi) {
    const int64_t now = now_utime();
    monitor.tick(now);
    spy::RenderOptions o;
    o.ansi = ansi;
    o.width = terminal_width();
    o.url = url;
    o.uptime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    o.kernel_drops = port != 0 ? bus::udp_drops(port) - drops0 : 0;
    const bus::ReceiverStats rs = rx.stats();
    o.malformed_datagrams = rs.malformed_datagrams;
    o.incomplete_messages = rs.incomplete_messages;
    o.authenticated = rs.authenticated;
    if (auth.key) o.key_id = bus::auth::key_id_hex(auth.key->id());
    o.auth_unsigned = rs.auth_unsigned;
    o.auth_bad_mac = rs.auth_bad_mac;
    o.auth_stale = rs.auth_stale;
    o.auth_replayed = rs.auth_replayed;
    o.now_utime = now;
    const std::string text = spy::render(monitor, o);
    std::fwrite(text.data(), 1, text.size(), stdout);
    std::fflush(stdout);
  };
  while (!quit) {
    const auto now = std::chrono::steady_clock::now();
    if (snapshot && std::chrono::duration<double>(now - t0).count() >= collect_s) break;
    if (now >= next_frame) {
      if (!snapshot) draw(true);
      else monitor.tick(now_utime());  // keep the rate window moving
      next_frame += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
      if (next_frame < now) next_frame = now;
    }
    const int wait_ms = static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(next_frame - now).count()) + 1;
    pollfd fds[3] = {{rx_fd, POLLIN, 0}, {sfd, POLLIN, 0}, {STDIN_FILENO, POLLIN, 0}};
    const nfds_t nfds = term && term->active() ? 3 : 2;
    if (::poll(fds, nfds, wait_ms) < 0) continue;
    if ((fds[0].revents & POLLIN) != 0) {
      // Drain what is queued without blocking, but yield to the screen at the frame time.
      do {
        if (rx.handle(0) <= 0) break;
      } while (std::chrono::steady_clock::now() < next_frame);
    }
    if ((fds[1].revents & POLLIN) != 0 && signals.wait(std::chrono::nanoseconds::zero()) != 0) quit = true;
    if (nfds == 3 && (fds[2].revents & POLLIN) != 0) {
      char c = 0;
      if (::read(STDIN_FILENO, &c, 1) == 1 && (c == 'q' || c == 'Q' || c == 3)) quit = true;
    }
  }
  if (snapshot) draw(false);
  term.reset();
}

}  // namespace

void add_spy(CLI::App& app) {
  auto a = std::make_shared<SpyArgs>();
  auto* cmd = app.add_subcommand("spy",
                                 "Terminal live view of the LCM bus: channels, rates, sequence gaps, drops and the "
                                 "latest decoded angle, raw block, cycle statistics and DAQ status (q quits)");
  cmd->add_option("--lcm-url", a->url, std::string("LCM URL (default $LCM_DEFAULT_URL or ") + bus::kHostOnlyUrl + ")");
  cmd->add_option("-c,--channels", a->channels, "Regex of the channels to show")->capture_default_str();
  cmd->add_option("--refresh", a->refresh_hz, "Screen refreshes per second")->check(CLI::Range(0.2, 50.0))->capture_default_str();
  cmd->add_flag("--once", a->once, "Listen for 1 s (or --duration), print one plain-text snapshot and exit");
  cmd->add_option("--duration", a->duration_s, "Listen this long [s], print one plain-text snapshot and exit")
      ->check(pof::service::positive(pof::service::kMaxSeconds));
  cmd->add_option("--queue-capacity", a->queue_capacity, "LCM subscription queue [messages] (transports other than udpm://)")
      ->check(pof::service::positive())
      ->capture_default_str();
  add_auth_options(cmd, a->auth);
  cmd->callback([a] { run_spy(*a); });
}

}  // namespace pof::cli
