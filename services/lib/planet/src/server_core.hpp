#pragma once
// What the Planet server owns (Server::Impl is a ServerCore): options, the acceptor and the I/O
// threads, the sessions and their admission limits, the authenticator and TLS context. Shared
// by server.cpp (listening, accepting, stopping) and server_session.cpp (one connection).

#include <algorithm>
#include <asio.hpp>
#include <asio/ssl.hpp>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "random.hpp"
#include "session_directory.hpp"
#include "stream.hpp"
#include "urs/planet/codec.hpp"
#include "urs/planet/fair_share.hpp"
#include "urs/planet/server.hpp"

namespace urs::planet {

class ServerSession;

// A session's buffers, counted in its credential's share of max_buffered_bytes.
class ShareBudget final : public BufferBudget {
 public:
  ShareBudget(std::shared_ptr<FairShare> share, FairShare::AccountPtr account)
      : share_(std::move(share)), account_(std::move(account)) {}
  bool take(uint64_t bytes, std::string& why) override {
    why = share_->take(*account_, bytes);
    return why.empty();
  }
  void force(uint64_t bytes) override { share_->force(*account_, bytes); }
  void give(uint64_t bytes) override { share_->give(*account_, bytes); }
  uint64_t used() const override { return account_->used(); }

 private:
  const std::shared_ptr<FairShare> share_;
  const FairShare::AccountPtr account_;
};

// Everything the server owns. Server::Impl is this; sessions name it ServerCore because
// Server::Impl is private.
struct ServerCore {
  ServerCore(ServerOptions options_in, SessionHandler& handler_in);

  void start();
  void stop();
  void do_accept();
  void on_session_closed(uint64_t id);
  bool on_io_thread() const;
  std::shared_ptr<const Authenticator> current_authenticator() const;
  // What a session may send once open (before Welcome: hello_limits()).
  CodecLimits session_limits() const;
  CodecLimits hello_limits() const;
  // With `mutex` held: why a new connection from `address` is refused, or empty; `limit` is set to
  // the name of the limit that refuses it.
  std::string connection_problem_locked(const std::string& address, std::string& limit) const;
  size_t set_authenticator(std::shared_ptr<const Authenticator> replacement);

  // Of `total`, what reserved_percent keeps for sam and operator sessions.
  uint64_t reserved_of(uint64_t total) const { return total * options.reserved_percent / 100; }

  const ServerOptions options;
  SessionHandler& handler;
  // options.max_connections, lowered to what the descriptors left at construction allow.
  const size_t max_connections;
  detail::SessionDirectory directory{options.session_resume_window,
                                     FairShare::Limits{
                                         options.max_resumable_sessions,
                                         options.max_resumable_sessions_per_credential,
                                         reserved_of(options.max_resumable_sessions),
                                         "max_resumable_sessions",
                                         "max_resumable_sessions_per_credential",
                                         "reserved_percent " + std::to_string(options.reserved_percent),
                                         "resumable sessions",
                                     }};
  // Open sessions by credential (max_connections, max_sessions_per_credential).
  const std::shared_ptr<FairShare> session_share = std::make_shared<FairShare>(FairShare::Limits{
      max_connections, options.max_sessions_per_credential, reserved_of(max_connections), "max_connections",
      "max_sessions_per_credential", "reserved_percent " + std::to_string(options.reserved_percent), "sessions"});
  // Reassembly buffers and send queues by credential (max_buffered_bytes and its shares).
  const std::shared_ptr<FairShare> buffer_share = std::make_shared<FairShare>(FairShare::Limits{
      options.max_buffered_bytes, std::min(options.max_buffered_bytes_per_credential, options.max_buffered_bytes),
      reserved_of(options.max_buffered_bytes), "max_buffered_bytes", "max_buffered_bytes_per_credential",
      "reserved_percent " + std::to_string(options.reserved_percent), "bytes buffered"});
  mutable std::mutex auth_mutex;
  std::shared_ptr<const Authenticator> authenticator;  // null: an open server
  const std::string instance = detail::random_hex(8);
  // One io_context per I/O thread, each connection on one of them in turn: a frame is read,
  // handled and written on by one thread, and no thread wakes another to take over the wait for
  // the next event (which threads sharing one io_context do on every event: two wake-ups instead
  // of one per frame).
  const std::vector<std::shared_ptr<asio::io_context>> ios = [n = options.io_threads] {
    std::vector<std::shared_ptr<asio::io_context>> out;
    for (unsigned i = 0; i < std::max(n, 1u); ++i) out.push_back(std::make_shared<asio::io_context>(1));
    return out;
  }();
  size_t next_io = 0;  // the io_context of the next connection; on the accept strand
  asio::strand<asio::io_context::executor_type> accept_strand{ios.front()->get_executor()};
  asio::ip::tcp::acceptor acceptor{accept_strand};
  asio::steady_timer accept_retry{accept_strand};
  std::vector<asio::executor_work_guard<asio::io_context::executor_type>> work;
  std::vector<std::thread> threads;
  uint16_t bound_port = 0;

  std::mutex mutex;
  std::condition_variable changed;
  std::map<uint64_t, std::shared_ptr<ServerSession>> sessions;  // handshaking and open
  std::map<std::string, size_t> connections_per_address;        // of `sessions`, by source address
  // Null: plain TCP. Replaced by reload_tls() (guarded by auth_mutex); a connection keeps the one
  // it was accepted with.
  std::shared_ptr<asio::ssl::context> tls =
      options.tls.cert_file.empty() ? nullptr : detail::make_server_tls_context(options.tls);
  std::shared_ptr<asio::ssl::context> current_tls() const {
    std::lock_guard<std::mutex> lock(auth_mutex);
    return tls;
  }
  uint64_t next_session_id = 1;
  // Since start (ServerStats): refusals by the server's own limits (the fair shares count theirs),
  // handshakes refused for their credential, connections closed for what they sent.
  Refusals refusals;
  Refusals authentication_failures;
  Refusals protocol_errors;
  bool started = false;
  bool stopped = false;
};

}  // namespace urs::planet
