#include "urs/planet/server.hpp"

#include <spdlog/spdlog.h>

#include <atomic>
#include <condition_variable>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "link.hpp"
#include "random.hpp"
#include "session_directory.hpp"
#include "urs/planet/codec.hpp"
#include "urs/planet/status.hpp"

namespace urs::planet {
namespace {

using std::chrono::milliseconds;

constexpr size_t kMaxPeerNameBytes = 128;

// Empty if `name` is an acceptable Hello.peer_name, else why not.
std::string peer_name_problem(const std::string& name) {
  if (name.empty()) return "it is empty";
  if (name.size() > kMaxPeerNameBytes) {
    return "it is " + std::to_string(name.size()) + " bytes long; the limit is " + std::to_string(kMaxPeerNameBytes);
  }
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                    c == '_' || c == '-' || c == '@' || c == ':' || c == '/';
    if (!ok) return "it holds a character other than letters, digits and . _ - @ : /";
  }
  if (name == "camus-server") return "'camus-server' is the server's own name";
  return {};
}

// Over a connection limit: one Refused{RESOURCE_EXHAUSTED} if the socket takes it at once (it
// is small and the socket new), then close. Nothing is read from the peer.
void refuse_connection(asio::ip::tcp::socket socket, const std::string& address, const std::string& reason) {
  detail::warn_peer(address + ":0", "refused a connection from " + address + ": " + reason);
  Frame refused;
  refused.mutable_refused()->set_status(Status::RESOURCE_EXHAUSTED);
  refused.mutable_refused()->set_reason(reason);
  const std::string bytes = encode_frame(refused);
  std::error_code ignored;
  socket.non_blocking(true, ignored);
  socket.write_some(asio::buffer(bytes), ignored);
  socket.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
  socket.close(ignored);
}

bool is_loopback(const std::string& host) {
  std::error_code error;
  const asio::ip::address address = asio::ip::make_address(host, error);
  if (error) return false;
  if (address.is_loopback()) return true;
  return address.is_v6() && address.to_v6().is_v4_mapped() &&
         asio::ip::make_address_v4(asio::ip::v4_mapped, address.to_v6()).is_loopback();
}

void validate(const ServerOptions& options) {
  std::vector<std::string> errors;
  auto ms = [](milliseconds value) { return std::to_string(value.count()) + " ms"; };
  if (options.heartbeat_interval.count() <= 0) {
    errors.push_back("heartbeat_interval " + ms(options.heartbeat_interval) + " must be > 0");
  }
  if (options.heartbeat_timeout <= options.heartbeat_interval) {
    errors.push_back("heartbeat_timeout " + ms(options.heartbeat_timeout) +
                     " must be longer than heartbeat_interval " + ms(options.heartbeat_interval));
  }
  if (options.handshake_timeout.count() <= 0) {
    errors.push_back("handshake_timeout " + ms(options.handshake_timeout) + " must be > 0");
  }
  check_message_limits(options.chunk_bytes, options.max_message_bytes, errors);
  if (options.max_send_queue_bytes < options.chunk_bytes) {
    errors.push_back("max_send_queue_bytes " + std::to_string(options.max_send_queue_bytes) +
                     " must be at least chunk_bytes (" + std::to_string(options.chunk_bytes) + ")");
  }
  if (options.max_hello_bytes < kMinChunkBytes || options.max_hello_bytes > options.chunk_bytes) {
    errors.push_back("max_hello_bytes " + std::to_string(options.max_hello_bytes) + " must be between " +
                     std::to_string(kMinChunkBytes) + " and chunk_bytes (" + std::to_string(options.chunk_bytes) + ")");
  }
  if (options.max_reassembly_bytes < options.max_message_bytes) {
    errors.push_back("max_reassembly_bytes " + std::to_string(options.max_reassembly_bytes) +
                     " must be at least max_message_bytes (" + std::to_string(options.max_message_bytes) + ")");
  }
  if (options.max_buffered_bytes < options.max_reassembly_bytes ||
      options.max_buffered_bytes < options.max_send_queue_bytes) {
    errors.push_back("max_buffered_bytes " + std::to_string(options.max_buffered_bytes) +
                     " must be at least max_reassembly_bytes and max_send_queue_bytes");
  }
  if (options.max_connections == 0 || options.max_connections_per_address == 0) {
    errors.push_back("max_connections and max_connections_per_address must be at least 1");
  }
  if (options.io_threads == 0) errors.push_back("io_threads must be at least 1");
  if (options.session_resume_window.count() < 0) {
    errors.push_back("session_resume_window " + ms(options.session_resume_window) + " must be >= 0");
  }
  if (options.max_resumable_sessions == 0) errors.push_back("max_resumable_sessions must be at least 1");
  if (errors.empty()) return;
  std::string message = "invalid Planet ServerOptions:";
  for (const auto& error : errors) message += "\n  " + error;
  throw std::invalid_argument(message);
}

}  // namespace

bool token_transport_allowed(bool tls, bool allow_plaintext_tokens, const std::string& peer_host) {
  return tls || allow_plaintext_tokens || is_loopback(peer_host);
}

class ServerSession;

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
  // With `mutex` held: why a new connection from `address` is refused, or empty.
  std::string connection_problem_locked(const std::string& address) const;
  size_t set_authenticator(std::shared_ptr<const Authenticator> replacement);

  const ServerOptions options;
  SessionHandler& handler;
  detail::SessionDirectory directory{options.session_resume_window, options.max_resumable_sessions};
  mutable std::mutex auth_mutex;
  std::shared_ptr<const Authenticator> authenticator;  // null: an open server
  const std::string instance = detail::random_hex(8);
  std::shared_ptr<asio::io_context> io = std::make_shared<asio::io_context>();
  asio::strand<asio::io_context::executor_type> accept_strand{io->get_executor()};
  asio::ip::tcp::acceptor acceptor{accept_strand};
  asio::steady_timer accept_retry{accept_strand};
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work;
  std::vector<std::thread> threads;
  uint16_t bound_port = 0;

  std::mutex mutex;
  std::condition_variable changed;
  std::map<uint64_t, std::shared_ptr<ServerSession>> sessions;  // handshaking and open
  std::map<std::string, size_t> connections_per_address;         // of `sessions`, by source address
  // Reassembly buffers and send queues of every session (max_buffered_bytes).
  const std::shared_ptr<MemoryBudget> budget = std::make_shared<MemoryBudget>(options.max_buffered_bytes);
  // Null: plain TCP.
  // Null: plain TCP. Replaced by reload_tls() (guarded by auth_mutex); a connection keeps the one
  // it was accepted with.
  std::shared_ptr<asio::ssl::context> tls =
      options.tls.cert_file.empty() ? nullptr : detail::make_server_tls_context(options.tls);
  std::shared_ptr<asio::ssl::context> current_tls() const {
    std::lock_guard<std::mutex> lock(auth_mutex);
    return tls;
  }
  uint64_t next_session_id = 1;
  bool started = false;
  bool stopped = false;
};

// One accepted connection: handshake, then frames to the SessionHandler.
class ServerSession final : public detail::Link, public Session {
 public:
  ServerSession(ServerCore& server, uint64_t id, std::unique_ptr<detail::Stream> stream,
                const detail::LinkConfig& config, std::string source_address)
      : Link(server.io, std::move(stream), config),
        server_(server),
        id_(id),
        source_address_(std::move(source_address)),
        handshake_timer_(executor()) {}

  // The peer's address without the port (what max_connections_per_address counts).
  const std::string& source_address() const { return source_address_; }

  // Starts the handshake timer and the read loop.
  void begin() {
    auto self = std::static_pointer_cast<ServerSession>(shared_from_this());
    asio::post(executor(), [self] {
      if (self->closing()) return;  // Server::stop() got here first
      self->handshake_timer_.expires_after(self->server_.options.handshake_timeout);
      self->handshake_timer_.async_wait([self](const std::error_code& error) {
        if (error || self->opened_) return;
        const std::string reason = "no Hello within " +
                                   std::to_string(self->server_.options.handshake_timeout.count()) +
                                   " ms";
        detail::warn_peer(self->peer_address(), "closing " + self->describe() + ": " + reason);
        self->close_link(detail::make_goodbye(Status::DEADLINE_EXCEEDED, reason), reason);
      });
      self->start();
    });
  }

  // Only after the io threads are gone (Server::stop fallback).
  void abandon(const std::string& reason) { finish(reason); }

  // The handshake succeeded: hello() and identity() are set and will not change.
  bool is_open() const { return opened_; }

  // Session
  uint64_t id() const override { return id_; }
  const Hello& hello() const override { return hello_; }
  const Identity& identity() const override { return identity_; }
  std::string remote_address() const override { return peer_address(); }
  bool send(Frame frame) override { return enqueue(std::move(frame)); }
  void close(Status status, const std::string& reason) override {
    close_link(detail::make_goodbye(status, reason), reason);
  }

 protected:
  // Link
  void handle_frame(Frame&& frame) override {
    if (!opened_) {
      handshake(std::move(frame));
      return;
    }
    if (frame.has_hello()) {
      protocol_violation("unexpected Hello: the session is already open");
      return;
    }
    server_.handler.on_frame(self(), std::move(frame));
  }

  void handle_closed(const std::string& reason) override {
    handshake_timer_.cancel();
    if (opened_) {
      server_.directory.closed(identity_.session, this);
      spdlog::info("planet: {} closed: {}", describe(), reason);
      try {
        server_.handler.on_close(self(), reason);
      } catch (const std::exception& exception) {
        spdlog::error("planet: SessionHandler::on_close of {} threw: {}", describe(),
                      exception.what());
      }
    }
    server_.on_session_closed(id_);
  }

  std::string describe() const override {
    std::string text = "session " + std::to_string(id_) + " from " + peer_address();
    if (opened_) text += " (" + identity_.name + ", peer '" + hello_.peer_name() + "')";
    return text;
  }

 private:
  SessionPtr self() { return std::static_pointer_cast<ServerSession>(shared_from_this()); }

  void protocol_violation(const std::string& reason) {
    detail::warn_peer(peer_address(), "closing " + describe() + ": " + reason);
    close_link(detail::make_goodbye(Status::BAD_ARGUMENTS, reason), reason);
  }

  // The peer's declared name is quoted only once it is known to be printable and short.
  void refuse(Status status, const std::string& reason, const Hello& hello) {
    const bool printable = peer_name_problem(hello.peer_name()).empty();
    detail::warn_peer(peer_address(), "refused peer '" + (printable ? hello.peer_name() : std::string("?")) +
                                          "' from " + peer_address() + ": " + reason);
    Frame refused;
    refused.mutable_refused()->set_status(status);
    refused.mutable_refused()->set_reason(reason);
    close_link(std::move(refused), "refused: " + reason);
  }

  // The verified client-certificate name; empty on a connection without one (plain TCP).
  std::string certificate_name() const { return peer_certificate_name(); }

  void handshake(Frame&& frame) {
    handshake_timer_.cancel();
    if (!frame.has_hello()) {
      protocol_violation("expected Hello as the first frame, got " +
                         std::string(frame_body_name(frame)));
      return;
    }
    Hello& hello = *frame.mutable_hello();
    const ServerOptions& options = server_.options;
    if (hello.version() != kProtocolVersion) {
      refuse(Status::INTERNAL,
             "protocol version " + std::to_string(hello.version()) +
                 " not supported, server speaks " + std::to_string(kProtocolVersion),
             hello);
      return;
    }
    if (auto why = peer_name_problem(hello.peer_name()); !why.empty()) {
      refuse(Status::BAD_ARGUMENTS, "peer_name is not valid: " + why, hello);
      return;
    }
    if (!hello.token().empty() &&
        !token_transport_allowed(secure(), options.allow_plaintext_tokens, source_address_)) {
      refuse(Status::UNAUTHENTICATED,
             "a token over plain TCP is accepted from loopback only: connect with TLS (--tls), or the operator "
             "starts the server with --allow-plaintext-tokens",
             hello);
      return;
    }
    Admission admission;
    if (auto authenticator = server_.current_authenticator()) {
      admission = authenticator->admit(hello.token(), certificate_name());
      if (!admission.ok()) {
        refuse(admission.status, admission.reason, hello);
        return;
      }
    } else {
      admission.name = kAnonymousIdentity;
      admission.role = Role::OPERATOR;
    }
    if (hello.role() > admission.role) {
      refuse(Status::PERMISSION_DENIED,
             "credential '" + admission.name + "' has role " + role_word(admission.role) + "; Hello asks for " +
                 role_word(hello.role()) + (hello.role() == Role::SAM ? " (to register services)" : ""),
             hello);
      return;
    }
    const std::string secret = hello.session_secret();
    hello.clear_token();
    hello.clear_session_secret();
    hello_ = std::move(hello);
    auto opened = server_.directory.open(secret, admission.name, self());
    identity_.name = std::move(admission.name);
    identity_.role = admission.role;
    identity_.session = opened.session;
    identity_.fingerprint = std::move(admission.fingerprint);

    Frame welcome_frame;
    Welcome& welcome = *welcome_frame.mutable_welcome();
    welcome.set_version(kProtocolVersion);
    welcome.set_space(options.space);
    welcome.set_server_instance(server_.instance);
    welcome.set_heartbeat_interval_ms(static_cast<uint32_t>(options.heartbeat_interval.count()));
    welcome.set_heartbeat_timeout_ms(static_cast<uint32_t>(options.heartbeat_timeout.count()));
    welcome.set_max_message_bytes(options.max_message_bytes);
    welcome.set_chunk_bytes(options.chunk_bytes);
    welcome.set_session_secret(opened.secret);
    welcome.set_identity(identity_.name);
    welcome.set_role(identity_.role);
    enqueue(std::move(welcome_frame));

    opened_ = true;
    mark_open();
    set_limits(server_.session_limits(), options.chunk_bytes);  // Hello limits no more
    set_heartbeat(options.heartbeat_interval, options.heartbeat_timeout);
    spdlog::info("planet: {} open: {} (role {}), session {}{}", describe(), identity_.name,
                 role_word(identity_.role), identity_.session, opened.resumed ? " resumed" : "");
    if (opened.previous) {
      spdlog::info("planet: session {} resumed by connection {}; closing its previous connection",
                   identity_.session, id_);
      opened.previous->close(Status::UNAVAILABLE, "session resumed from another connection");
    }
    server_.handler.on_open(self());
  }

  ServerCore& server_;
  const uint64_t id_;
  const std::string source_address_;
  asio::steady_timer handshake_timer_;
  Hello hello_;        // written once on the strand before on_open; read-only afterwards
  Identity identity_;  // likewise
  std::atomic<bool> opened_{false};  // set on the strand after hello_; read anywhere
};

ServerCore::ServerCore(ServerOptions options_in, SessionHandler& handler_in)
    : options((validate(options_in), std::move(options_in))),
      handler(handler_in),
      authenticator(options.authenticator) {
  const std::string where = options.host + ":" + std::to_string(options.port);
  try {
    asio::ip::tcp::resolver resolver(*io);
    auto results = resolver.resolve(options.host, std::to_string(options.port),
                                    asio::ip::tcp::resolver::passive |
                                        asio::ip::tcp::resolver::numeric_service);
    if (results.empty()) throw std::runtime_error("no address");
    const asio::ip::tcp::endpoint endpoint = results.begin()->endpoint();
    acceptor.open(endpoint.protocol());
    acceptor.set_option(asio::ip::tcp::acceptor::reuse_address(true));
    acceptor.bind(endpoint);
    acceptor.listen(asio::socket_base::max_listen_connections);
    bound_port = acceptor.local_endpoint().port();
  } catch (const std::exception& exception) {
    throw std::runtime_error("Planet server cannot listen on " + where + ": " + exception.what() +
                             " (is another process using the port? choose another with --listen)");
  }
}

bool ServerCore::on_io_thread() const {
  for (const auto& thread : threads) {
    if (thread.get_id() == std::this_thread::get_id()) return true;
  }
  return false;
}

void ServerCore::start() {
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (started || stopped) return;
    started = true;
  }
  work.emplace(io->get_executor());
  asio::post(accept_strand, [this] { do_accept(); });
  for (unsigned i = 0; i < options.io_threads; ++i) {
    threads.emplace_back([this] { detail::run_io(*io, "server"); });
  }
  spdlog::info("planet: server listening on {}:{} (space '{}', instance {}, {})", options.host, bound_port,
               options.space, instance,
               !tls ? "plain TCP" : options.tls.ca_file.empty() ? "TLS 1.3" : "TLS 1.3, client certificates verified");
}

void ServerCore::do_accept() {
  acceptor.async_accept(
      asio::make_strand(*io), [this](const std::error_code& error, asio::ip::tcp::socket socket) {
        if (error == asio::error::operation_aborted || !acceptor.is_open()) return;
        if (error) {
          // E.g. out of file descriptors: retry shortly instead of spinning.
          spdlog::warn("planet: accept failed on port {}: {}", bound_port, error.message());
          accept_retry.expires_after(std::chrono::milliseconds(100));
          accept_retry.async_wait([this](const std::error_code& wait_error) {
            if (!wait_error) do_accept();
          });
          return;
        }
        std::shared_ptr<ServerSession> session;
        std::error_code address_error;
        const auto remote = socket.remote_endpoint(address_error);
        const std::string address = address_error ? "?" : remote.address().to_string();
        std::string refusal;
        {
          std::lock_guard<std::mutex> lock(mutex);
          if (stopped) return;  // the socket closes as it goes out of scope
          refusal = connection_problem_locked(address);
          if (refusal.empty()) {
            detail::LinkConfig config;
            config.limits = hello_limits();
            config.chunk_bytes = options.chunk_bytes;
            config.max_send_queue_bytes = options.max_send_queue_bytes;
            config.budget = budget;
            const uint64_t id = next_session_id++;
            auto context = current_tls();
            auto stream = context ? detail::make_tls_stream(std::move(socket), context, /*server=*/true)
                                  : detail::make_tcp_stream(std::move(socket));
            session = std::make_shared<ServerSession>(*this, id, std::move(stream), config, address);
            sessions.emplace(id, session);
            ++connections_per_address[address];
          }
        }
        if (!refusal.empty()) {
          refuse_connection(std::move(socket), address, refusal);
          do_accept();
          return;
        }
        spdlog::debug("planet: accepted {}", session->remote_address());
        session->begin();
        do_accept();
      });
}

CodecLimits ServerCore::session_limits() const {
  CodecLimits limits;
  limits.max_frame_bytes = options.chunk_bytes;
  limits.max_message_bytes = options.max_message_bytes;
  limits.max_reassembly_bytes = options.max_reassembly_bytes;
  return limits;
}

CodecLimits ServerCore::hello_limits() const {
  CodecLimits limits = session_limits();
  limits.max_frame_bytes = options.max_hello_bytes;
  limits.before_handshake = true;
  return limits;
}

std::string ServerCore::connection_problem_locked(const std::string& address) const {
  if (sessions.size() >= options.max_connections) {
    return "the server has " + std::to_string(sessions.size()) + " connections open, the limit (max_connections " +
           std::to_string(options.max_connections) + "); retry later";
  }
  auto it = connections_per_address.find(address);
  const size_t from_address = it == connections_per_address.end() ? 0 : it->second;
  if (from_address >= options.max_connections_per_address) {
    return std::to_string(from_address) + " connections are open from " + address +
           ", the limit (max_connections_per_address " + std::to_string(options.max_connections_per_address) +
           "); retry later";
  }
  return {};
}

std::shared_ptr<const Authenticator> ServerCore::current_authenticator() const {
  std::lock_guard<std::mutex> lock(auth_mutex);
  return authenticator;
}

size_t ServerCore::set_authenticator(std::shared_ptr<const Authenticator> replacement) {
  {
    std::lock_guard<std::mutex> lock(auth_mutex);
    authenticator = replacement;
  }
  std::vector<std::shared_ptr<ServerSession>> all;
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (auto& [id, session] : sessions) all.push_back(session);
  }
  std::set<std::string> revoked;
  size_t closed = 0;
  for (auto& session : all) {
    if (!session->is_open()) continue;
    const Identity& identity = session->identity();
    const std::string now = replacement ? replacement->fingerprint(identity.name) : std::string();
    const bool still = replacement ? (!now.empty() && now == identity.fingerprint) : true;
    if (still) continue;
    revoked.insert(identity.name);
    spdlog::warn("planet: closing session {} of '{}': its credential was changed or revoked", identity.session,
                 identity.name);
    session->close(Status::UNAUTHENTICATED, "credential '" + identity.name +
                                                "' was changed or revoked by the operator; reconnect with a current one");
    ++closed;
  }
  for (const auto& name : revoked) directory.forget_identity(name);
  return closed;
}

void ServerCore::on_session_closed(uint64_t id) {
  std::lock_guard<std::mutex> lock(mutex);
  auto it = sessions.find(id);
  if (it == sessions.end()) return;
  auto count = connections_per_address.find(it->second->source_address());
  if (count != connections_per_address.end() && --count->second == 0) connections_per_address.erase(count);
  sessions.erase(it);
  changed.notify_all();
}

void ServerCore::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (stopped) return;
    stopped = true;
  }
  if (threads.empty()) {
    std::error_code ignored;
    acceptor.close(ignored);
    return;
  }
  if (on_io_thread()) {
    throw std::logic_error("planet::Server::stop() called from one of its own I/O threads");
  }
  asio::post(accept_strand, [this] {
    std::error_code ignored;
    acceptor.close(ignored);
    accept_retry.cancel();
  });
  std::vector<std::shared_ptr<ServerSession>> all;
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (auto& [id, session] : sessions) all.push_back(session);
  }
  for (auto& session : all) {
    session->close_link(detail::make_goodbye(Status::UNAVAILABLE, "server shutting down"),
                        "server stopped");
  }
  all.clear();
  bool drained = false;
  {
    std::unique_lock<std::mutex> lock(mutex);
    // Each close takes at most the linger time (1 s) to send its Goodbye.
    drained = changed.wait_for(lock, std::chrono::seconds(10), [this] { return sessions.empty(); });
  }
  work.reset();
  if (!drained) {
    spdlog::error("planet: sessions did not close within 10 s; stopping the I/O threads anyway");
    io->stop();
  }
  for (auto& thread : threads) thread.join();
  threads.clear();
  // Only if the io_context was stopped: close what is left here, so on_close still runs once.
  std::map<uint64_t, std::shared_ptr<ServerSession>> left;
  {
    std::lock_guard<std::mutex> lock(mutex);
    left = sessions;
  }
  for (auto& [id, session] : left) session->abandon("server stopped");
  spdlog::info("planet: server on port {} stopped", bound_port);
}

struct Server::Impl : ServerCore {
  using ServerCore::ServerCore;
};

Server::Server(ServerOptions options, SessionHandler& handler)
    : impl_(std::make_unique<Impl>(std::move(options), handler)) {}

Server::~Server() { stop(); }

uint16_t Server::port() const { return impl_->bound_port; }

void Server::start() { impl_->start(); }

void Server::stop() { impl_->stop(); }

void Server::reload_tls(const util::TlsConfig& tls) {
  if (!impl_->current_tls()) {
    throw std::logic_error("this Planet server speaks plain TCP: it cannot switch to TLS while running");
  }
  auto context = detail::make_server_tls_context(tls);  // throws, naming the file, before anything changes
  std::lock_guard<std::mutex> lock(impl_->auth_mutex);
  impl_->tls = std::move(context);
}

size_t Server::set_authenticator(std::shared_ptr<const Authenticator> authenticator) {
  return impl_->set_authenticator(std::move(authenticator));
}

}  // namespace urs::planet
