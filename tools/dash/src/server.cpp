// Compiled as C++17 (tools/dash/CMakeLists.txt): see server.hpp.
#include "pof/dash/server.hpp"

#include <atomic>
#include <chrono>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>
#include <utility>

#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include "pof/base/errors.hpp"

namespace pof::dash {
namespace {

using WsServer = websocketpp::server<websocketpp::config::asio>;
using Hdl = websocketpp::connection_hdl;

std::string content_type(const std::string& path) {
  auto ends = [&](const char* ext) {
    const std::string e(ext);
    return path.size() >= e.size() && path.compare(path.size() - e.size(), e.size(), e) == 0;
  };
  if (ends(".html") || path == "/") return "text/html; charset=utf-8";
  if (ends(".js")) return "text/javascript; charset=utf-8";
  if (ends(".css")) return "text/css; charset=utf-8";
  if (ends(".json")) return "application/json";
  if (ends(".svg")) return "image/svg+xml";
  return "application/octet-stream";
}

// "http://host:port" -> "host:port": what a browser's Origin says it came from,
// to compare with the Host it asked.
std::string origin_host(const std::string& origin) {
  const auto p = origin.find("://");
  return p == std::string::npos ? origin : origin.substr(p + 3);
}

}  // namespace

struct Server::Impl {
  struct File {
    std::string body;
    std::string type;
  };

  ServerOptions opt;
  TickFn tick;
  FrameFn frame;
  std::map<std::string, File> files;
  WsServer ws;
  std::unique_ptr<asio::steady_timer> timer;
  std::map<Hdl, Cursor, std::owner_less<Hdl>> clients;  // server thread only
  std::thread thread;
  uint16_t port = 0;
  bool started = false;
  bool stopped = false;
  std::atomic<uint64_t> n_clients{0}, frames_sent{0}, frames_skipped{0}, http_requests{0}, refused{0};
  mutable std::mutex error_mu;
  std::string error;

  void set_error(const std::string& e) {
    const std::lock_guard<std::mutex> lock(error_mu);
    error = e;
  }

  void on_http(Hdl h) {
    ++http_requests;
    const WsServer::connection_ptr con = ws.get_con_from_hdl(h);
    con->append_header("Cache-Control", "no-store");
    con->append_header("X-Content-Type-Options", "nosniff");
    const std::string method = con->get_request().get_method();
    std::string path = con->get_resource();
    if (const auto q = path.find('?'); q != std::string::npos) path.resize(q);
    if (method != "GET" && method != "HEAD") {
      ++refused;
      con->append_header("Allow", "GET, HEAD");
      con->set_status(websocketpp::http::status_code::method_not_allowed);
      return;
    }
    if (path == "/api/state") {
      Cursor fresh;
      try {
        con->set_body(frame(fresh));
        con->append_header("Content-Type", "application/json");
        con->set_status(websocketpp::http::status_code::ok);
      } catch (const std::exception& e) {
        set_error(std::string("/api/state: ") + e.what());
        con->set_status(websocketpp::http::status_code::internal_server_error);
      }
      return;
    }
    const auto it = files.find(path);
    if (it == files.end()) {
      ++refused;
      con->set_body("not found\n");
      con->set_status(websocketpp::http::status_code::not_found);
      return;
    }
    con->append_header("Content-Type", it->second.type);
    if (method == "GET") con->set_body(it->second.body);
    con->set_status(websocketpp::http::status_code::ok);
  }

  bool on_validate(Hdl h) {
    const WsServer::connection_ptr con = ws.get_con_from_hdl(h);
    const std::string origin = con->get_origin();
    if (origin.empty() || origin_host(origin) == con->get_request_header("Host")) return true;
    ++refused;
    con->set_status(websocketpp::http::status_code::forbidden);
    return false;
  }

  void on_tick() {
    try {
      tick();
    } catch (const std::exception& e) {
      set_error(std::string("tick: ") + e.what());
    }
    for (auto& [h, cursor] : clients) {
      std::error_code ec;
      const WsServer::connection_ptr con = ws.get_con_from_hdl(h, ec);
      if (ec || con->get_state() != websocketpp::session::state::open) continue;
      if (con->get_buffered_amount() > opt.max_buffered_bytes) {
        ++frames_skipped;
        continue;
      }
      try {
        ws.send(h, frame(cursor), websocketpp::frame::opcode::text, ec);
      } catch (const std::exception& e) {
        set_error(std::string("frame: ") + e.what());
        continue;
      }
      if (ec)
        set_error("send: " + ec.message());
      else
        ++frames_sent;
    }
  }

  void schedule() {
    const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(1.0 / opt.frame_hz));
    timer->expires_after(period);
    timer->async_wait([this](const std::error_code& ec) {
      if (ec) return;  // cancelled: stopping
      on_tick();
      schedule();
    });
  }
};

Server::Server(ServerOptions options, TickFn tick, FrameFn frame) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.opt = std::move(options);
  m.tick = std::move(tick);
  m.frame = std::move(frame);
  if (!(m.opt.frame_hz > 0)) m.opt.frame_hz = 20;
  for (const auto& [url, file] : m.opt.files) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream body;
    body << in.rdbuf();
    if (!in) throw pof::NoInputError(file + ": cannot read the dashboard's file for " + url);
    m.files[url] = Impl::File{body.str(), content_type(url == "/" ? file : url)};
  }

  m.ws.clear_access_channels(websocketpp::log::alevel::all);  // one line per frame otherwise
  m.ws.clear_error_channels(websocketpp::log::elevel::all);   // failures reach last_error()
  m.ws.init_asio();
  m.ws.set_reuse_addr(true);
  m.ws.set_http_handler([&m](Hdl h) { m.on_http(h); });
  m.ws.set_validate_handler([&m](Hdl h) { return m.on_validate(h); });
  m.ws.set_open_handler([&m](Hdl h) {
    m.clients.emplace(h, Cursor{});
    m.n_clients = m.clients.size();
  });
  auto gone = [&m](Hdl h) {
    m.clients.erase(h);
    m.n_clients = m.clients.size();
  };
  m.ws.set_close_handler(gone);
  m.ws.set_fail_handler(gone);

  std::error_code ec;
  const asio::ip::address addr = asio::ip::make_address(m.opt.address, ec);
  if (ec) throw pof::ConfigError("--listen " + m.opt.address + ": not an IP address (" + ec.message() + ")");
  m.ws.listen(asio::ip::tcp::endpoint(addr, m.opt.port), ec);
  if (ec)
    throw pof::ConfigError("cannot listen on " + m.opt.address + ":" + std::to_string(m.opt.port) + ": " +
                           ec.message());
  m.ws.start_accept(ec);
  if (ec) throw pof::IoError("cannot accept on " + m.opt.address + ": " + ec.message());
  const auto local = m.ws.get_local_endpoint(ec);
  m.port = ec ? m.opt.port : local.port();
  m.timer = std::make_unique<asio::steady_timer>(m.ws.get_io_service());
}

Server::~Server() { stop(); }

void Server::start() {
  Impl& m = *impl_;
  if (m.started) return;
  m.started = true;
  m.schedule();
  m.thread = std::thread([&m] {
    for (;;) {  // a handler that throws past websocketpp ends run(); serving
                // goes on
      try {
        m.ws.run();
        return;
      } catch (const std::exception& e) {
        m.set_error(std::string("server: ") + e.what());
      }
    }
  });
}

void Server::stop() {
  Impl& m = *impl_;
  if (m.stopped) return;
  m.stopped = true;
  if (!m.started) return;
  asio::post(m.ws.get_io_service(), [&m] {
    std::error_code ec;
    m.ws.stop_listening(ec);
    m.timer->cancel();
    for (auto& [h, cursor] : m.clients)
      m.ws.close(h, websocketpp::close::status::going_away, "pof dash stops", ec);
  });
  // Give the browsers' close handshakes a moment, then stop whatever is left.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (m.n_clients > 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  m.ws.stop();
  if (m.thread.joinable()) m.thread.join();
}

uint16_t Server::port() const { return impl_->port; }

ServerStats Server::stats() const {
  const Impl& m = *impl_;
  return ServerStats{m.n_clients, m.frames_sent, m.frames_skipped, m.http_requests, m.refused};
}

std::string Server::last_error() const {
  const std::lock_guard<std::mutex> lock(impl_->error_mu);
  return impl_->error;
}

}  // namespace pof::dash
