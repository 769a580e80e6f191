#pragma once
// The client's connection to its server: connect (resolve, TCP, TLS), the Hello/Welcome handshake
// resuming the session when the server knows its secret, heartbeats, and reconnecting with
// jittered exponential backoff (reconnect_min .. reconnect_max) whenever an attempt or a session
// fails. What the session carries is the SessionListener's business.
//
// Threading: the Connection's work runs on the client's I/O thread (one thread runs `io`); the
// queries (connected, wait_connected, last_error, welcome) are thread-safe.

#include <asio.hpp>
#include <asio/ssl.hpp>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include "client/deferred.hpp"
#include "client/frame_sink.hpp"
#include "urs/planet/client.hpp"

namespace urs::planet::detail {

// What a Connection tells its owner. Called on the I/O thread.
class SessionListener {
 public:
  // The handshake succeeded: restore what lives across sessions on `sink` (the server takes
  // messages up to `send_limit` bytes). Called with the connection's lock held: no connection
  // query answers "connected" before it returns.
  virtual void session_opened(const std::shared_ptr<FrameSink>& sink, const Welcome& welcome, uint64_t send_limit,
                              Deferred& out) = 0;
  // A frame of the open session (no lock held).
  virtual void session_frame(const std::shared_ptr<FrameSink>& sink, Frame&& frame) = 0;
  // The connection closed (lock held); `was_open` if its handshake had succeeded, `reason` says why.
  virtual void session_closed(const std::string& reason, bool was_open, Deferred& out) = 0;

 protected:
  ~SessionListener() = default;
};

class ClientLink;

class Connection {
 public:
  // `options` (validated) and `listener` must outlive the Connection; so must `io` run no more
  // after it is destroyed (the owner joins the I/O thread first).
  Connection(const ClientOptions& options, std::shared_ptr<asio::io_context> io, SessionListener& listener);
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  const std::string& target() const { return target_; }

  // I/O thread: the first connection attempt.
  void start();
  // I/O thread (or before it ever ran): no more attempts; closes the session with Goodbye OK
  // "client stopped"; wait_connected() returns false from now on.
  void shutdown();

  bool connected() const;
  bool wait_connected(std::chrono::milliseconds timeout) const;
  std::string last_error() const;
  Welcome welcome() const;

 private:
  friend class ClientLink;
  enum class Phase { kIdle, kConnecting, kHandshaking, kOpen };

  void start_connect();
  void connect_to(uint64_t attempt, std::vector<asio::ip::tcp::endpoint> endpoints);
  void on_socket_connected(uint64_t attempt, const std::error_code& error);
  void arm_connect_timer_locked(uint64_t attempt);
  void on_connect_timer(uint64_t attempt);
  // With mutex_ held: why the attempt failed, "timed out" if the connect timer fired first.
  std::string attempt_failure_locked(const std::string& error) const;
  void attempt_failed_locked(const std::string& reason);
  void schedule_reconnect_locked();
  void on_link_frame(const std::shared_ptr<ClientLink>& link, Frame&& frame);
  void on_handshake_frame_locked(const std::shared_ptr<ClientLink>& link, const Frame& frame, Deferred& out);
  void on_welcome_locked(const std::shared_ptr<ClientLink>& link, const Welcome& welcome, Deferred& out);
  void on_link_closed(const std::shared_ptr<ClientLink>& link, const std::string& reason);

  const ClientOptions& options_;
  const std::string target_;  // "host:port"
  // Null: plain TCP. Built once (the CA and client certificate are read at construction).
  const std::shared_ptr<asio::ssl::context> tls_;
  const std::shared_ptr<asio::io_context> io_;
  SessionListener& listener_;

  // I/O thread only.
  asio::ip::tcp::resolver resolver_;
  std::shared_ptr<asio::ip::tcp::socket> connecting_;

  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  Phase phase_ = Phase::kIdle;
  bool stopped_ = false;
  uint64_t generation_ = 0;  // of the current connection attempt
  bool connect_timed_out_ = false;
  asio::steady_timer reconnect_timer_;
  asio::steady_timer connect_timer_;
  std::shared_ptr<ClientLink> link_;
  Welcome welcome_;             // of the current (or last) session, its session_secret cleared
  std::string session_secret_;  // the server's, presented in the next Hello; never logged
  std::string last_error_;
  unsigned failures_ = 0;  // consecutive failed attempts, for the backoff
  std::mt19937_64 rng_{std::random_device{}()};
};

}  // namespace urs::planet::detail
