#pragma once
// The web side of `pof dash`: a few static files over HTTP and one WebSocket
// per browser, on one thread of its own (websocketpp on standalone asio,
// Debian's libwebsocketpp-dev and libasio-dev). Every tick it asks the caller
// for each open browser's frame (Model::frame through a Cursor of that browser)
// and sends it, unless the browser's send buffer still holds more than
// max_buffered_bytes: that frame is skipped and counted, and the next one
// carries what it missed (the Cursor), so a slow tablet never makes the server
// queue without bound nor blocks the bus.
//
// Read-only: GET and HEAD of the files it was given and of /api/state (one
// frame from a new cursor: the whole window as JSON); every other path or
// method is refused. A WebSocket whose Origin names another host than the one
// asked is refused, so a foreign page in the clinician's browser cannot read
// the session.
//
// This header is C++17: server.cpp is compiled as C++17, because websocketpp
// 0.8.2's headers do not compile as C++20 (template-ids on constructors,
// dropped in C++20).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "pof/dash/model.hpp"

namespace pof::dash {

struct ServerOptions {
  std::string address = "127.0.0.1";         // 0.0.0.0 (or a LAN address) only when asked to
  uint16_t port = 8090;                      // 0: any free port (tests), see Server::port()
  std::map<std::string, std::string> files;  // URL path ("/", "/dash.js") -> file to serve
  double frame_hz = 20;
  std::size_t max_buffered_bytes = 1u << 20;
};

struct ServerStats {
  uint64_t clients = 0;  // open WebSockets
  uint64_t frames_sent = 0;
  uint64_t frames_skipped = 0;  // skipped for a full send buffer
  uint64_t http_requests = 0;
  uint64_t refused = 0;  // requests and WebSockets refused (method, path, origin)
};

class Server {
 public:
  /// Called on the server thread once per tick, before the frames.
  using TickFn = std::function<void()>;
  /// Called on the server thread for each browser: the text of its next frame.
  using FrameFn = std::function<std::string(Cursor&)>;

  /// Reads every file (NoInputError naming one that cannot be read) and binds
  /// the address (ConfigError naming it when it cannot be bound). Serves
  /// nothing until start().
  Server(ServerOptions options, TickFn tick, FrameFn frame);
  ~Server();  // stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  void start();
  /// Closes every connection and joins the thread. Idempotent.
  void stop();
  /// The bound port (the chosen one when options.port was 0).
  [[nodiscard]] uint16_t port() const;
  [[nodiscard]] ServerStats stats() const;
  /// The text of the last error the server thread met ("" when none).
  [[nodiscard]] std::string last_error() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pof::dash
