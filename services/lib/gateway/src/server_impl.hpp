#pragma once
// What the gateway's Server owns (Server::Impl): its options, the Hub and Logins it serves, the
// I/O context and acceptor, the login worker, the connection and client counts its limits are
// checked against, and the WebSocket sessions it detaches when it stops. Shared by server.cpp
// (listening, accepting, stopping) and http_session.cpp (one connection, which reads the options
// and counts and registers its WebSocket session here).
//
// Threads: `connections` and `clients` are atomics; `sessions` is guarded by `sessions_mutex`;
// the rest is set up before start() and read only, but for the acceptor (I/O thread, then stop()).

#include <atomic>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <cstddef>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "urs/agent/agent.hpp"
#include "urs/gateway/server.hpp"
#include "ws_session.hpp"

namespace urs::gateway {

// Members in this order: the I/O context goes first when destroyed (with the handlers it still
// holds, and the sessions they keep), while the counters those sessions update still exist.
struct Server::Impl {
  Impl(ServerOptions options, Hub& hub, Logins& logins)
      : options(std::move(options)), hub(hub), logins(logins), acceptor(ioc) {}

  const ServerOptions options;
  Hub& hub;
  Logins& logins;
  agent::WorkerPool login_pool{1};
  std::atomic<std::size_t> connections{0};
  std::atomic<std::size_t> clients{0};
  std::mutex sessions_mutex;
  std::vector<std::weak_ptr<WsSession>> sessions;
  bool stopped = false;
  std::thread thread;
  boost::asio::io_context ioc{1};
  boost::asio::ip::tcp::acceptor acceptor;

  // Accepts the next connection (I/O thread): refused at once beyond max_connections, else an
  // HttpSession of its own.
  void accept();
  // Registers a WebSocket session, so that stop() and end_sessions() find it (any thread).
  void add_session(const std::shared_ptr<WsSession>& session);
  // Closes every WebSocket of the login `id` with `reason` (any thread); returns how many.
  std::size_t end_sessions(const std::string& id, const std::string& reason);
};

}  // namespace urs::gateway
