#pragma once
// The gateway's one port (docs/dashboard.md): HTTP for the dashboard's static files and its login,
// and at ws://HOST:PORT/ the Foxglove WebSocket protocol (subprotocol foxglove.websocket.v1),
// whose messages go to the Hub. The only code of the gateway that touches sockets (Boost.Beast).
// Its parts, one a file under src/: server.cpp (listen, accept, stop), http_session.cpp (one HTTP
// connection: files, login, upgrade), ws_session.cpp (one WebSocket client and its bounded
// queue), http_util.cpp (reading requests, building responses).
//
//   GET  /, /<file>        the dashboard (files of `web_dir`; nothing else is served)
//   POST /api/login        {"credential": "..."} -> {"role", "session", "space"} and the session cookie
//   POST /api/logout       ends the cookie's login
//   GET  /api/whoami       {"space", "role", "anonymous"}: what this browser may do now
//   GET  / with Upgrade    the WebSocket; the login from the cookie or ?session=<id>, else the
//                          anonymous role if one is allowed, else 401
//
// Limits (hostile peers): request headers 8 KiB, bodies 4 KiB, a request must arrive within the
// HTTP timeout, `max_connections` TCP connections, `max_clients` WebSocket clients, client messages
// of foxglove::kMaxBinaryMessage bytes, and `max_queue_bytes` not yet sent per client: a client
// slower than what it subscribed to is dropped (close code 1008), never buffered without bound.
//
// Threads: one I/O thread runs every socket; logins are verified on a thread of their own (they
// block). Outboxes may be filled from any thread.

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "urs/gateway/hub.hpp"
#include "urs/gateway/logins.hpp"

namespace urs::gateway {

struct ServerOptions {
  std::string host = "127.0.0.1";
  uint16_t port = 0;    // 0: any free port (see port())
  std::string web_dir;  // the dashboard's files
  std::string space;
  std::optional<Role> anonymous;  // the role of a connection without a login; none: refused
  std::size_t max_connections = 256;
  std::size_t max_clients = 64;
  std::size_t max_queue_bytes = 8u << 20;
  std::chrono::seconds http_timeout{30};
};

class Server {
 public:
  // Binds and listens; throws std::runtime_error naming the address if it cannot.
  // `hub` and `logins` outlive this.
  Server(ServerOptions options, Hub& hub, Logins& logins);
  ~Server();  // stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  void start();  // starts the I/O thread; returns at once
  void stop();   // closes every connection and joins
  uint16_t port() const;

  struct Impl;  // implementation detail

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace urs::gateway
