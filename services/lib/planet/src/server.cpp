#include "urs/planet/server.hpp"

#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "link.hpp"
#include "server_core.hpp"
#include "server_session.hpp"
#include "urs/planet/codec.hpp"
#include "urs/planet/status.hpp"

namespace urs::planet {
namespace {

using std::chrono::milliseconds;

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

// Descriptors the server keeps for itself beyond its connections (its databases, files read on a
// reload, the I/O threads' event descriptors, logs).
constexpr size_t kDescriptorMargin = 64;

// What the descriptor limit (RLIMIT_NOFILE, soft) leaves for connections: the limit, less the
// descriptors open now and kDescriptorMargin.
size_t connections_descriptors_allow() {
  rlimit limit{};
  if (getrlimit(RLIMIT_NOFILE, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return SIZE_MAX;
  size_t open = 0;
  std::error_code error;
  for (auto it = std::filesystem::directory_iterator("/proc/self/fd", error);
       !error && it != std::filesystem::directory_iterator(); it.increment(error)) {
    ++open;
  }
  const size_t used = open + kDescriptorMargin;
  return limit.rlim_cur > used ? static_cast<size_t>(limit.rlim_cur) - used : 1;
}

size_t applied_max_connections(const ServerOptions& options) {
  const size_t allowed = connections_descriptors_allow();
  if (options.max_connections <= allowed) return options.max_connections;
  spdlog::warn(
      "planet: max_connections lowered from {} to {}: the process may open {} more file descriptors "
      "(RLIMIT_NOFILE) and keeps {} for itself; raise the limit (ulimit -n, LimitNOFILE=) to allow more",
      options.max_connections, allowed, allowed + kDescriptorMargin, kDescriptorMargin);
  return allowed;
}

void validate(const ServerOptions& options) {
  std::vector<std::string> errors;
  auto ms = [](milliseconds value) { return std::to_string(value.count()) + " ms"; };
  if (options.heartbeat_interval.count() <= 0) {
    errors.push_back("heartbeat_interval " + ms(options.heartbeat_interval) + " must be > 0");
  }
  if (options.heartbeat_timeout <= options.heartbeat_interval) {
    errors.push_back("heartbeat_timeout " + ms(options.heartbeat_timeout) + " must be longer than heartbeat_interval " +
                     ms(options.heartbeat_interval));
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
  if (options.max_connections == 0 || options.max_connections_per_address == 0 ||
      options.max_sessions_per_credential == 0) {
    errors.push_back("max_connections, max_connections_per_address and max_sessions_per_credential must be at least 1");
  }
  if (std::min(options.max_buffered_bytes_per_credential, options.max_buffered_bytes) <
      std::max<uint64_t>(options.max_reassembly_bytes, options.max_send_queue_bytes)) {
    errors.push_back("max_buffered_bytes_per_credential " + std::to_string(options.max_buffered_bytes_per_credential) +
                     " must be at least max_reassembly_bytes and max_send_queue_bytes");
  }
  if (options.reserved_percent > 90) {
    errors.push_back("reserved_percent " + std::to_string(options.reserved_percent) + " must be at most 90");
  }
  if (options.io_threads == 0) errors.push_back("io_threads must be at least 1");
  if (options.session_resume_window.count() < 0) {
    errors.push_back("session_resume_window " + ms(options.session_resume_window) + " must be >= 0");
  }
  if (options.max_resumable_sessions == 0 || options.max_resumable_sessions_per_credential == 0) {
    errors.push_back("max_resumable_sessions and max_resumable_sessions_per_credential must be at least 1");
  }
  if (errors.empty()) return;
  std::string message = "invalid Planet ServerOptions:";
  for (const auto& error : errors) message += "\n  " + error;
  throw std::invalid_argument(message);
}

}  // namespace

bool token_transport_allowed(bool tls, bool allow_plaintext_tokens, const std::string& peer_host) {
  return tls || allow_plaintext_tokens || is_loopback(peer_host);
}

ServerCore::ServerCore(ServerOptions options_in, SessionHandler& handler_in)
    : options((validate(options_in), std::move(options_in))),
      handler(handler_in),
      max_connections(applied_max_connections(options)),
      authenticator(options.authenticator) {
  const std::string where = options.host + ":" + std::to_string(options.port);
  try {
    asio::ip::tcp::resolver resolver(*ios.front());
    auto results = resolver.resolve(options.host, std::to_string(options.port),
                                    asio::ip::tcp::resolver::passive | asio::ip::tcp::resolver::numeric_service);
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
  for (const auto& io : ios) work.push_back(asio::make_work_guard(*io));
  asio::post(accept_strand, [this] { do_accept(); });
  for (const auto& io : ios) {
    threads.emplace_back([io] { detail::run_io(*io, "server"); });
  }
  spdlog::info("planet: server listening on {}:{} (space '{}', instance {}, {}, max_connections {})", options.host,
               bound_port, options.space, instance,
               !tls                          ? "plain TCP"
               : options.tls.ca_file.empty() ? "TLS 1.3"
                                             : "TLS 1.3, client certificates verified",
               max_connections);
}

void ServerCore::do_accept() {
  auto io = ios[next_io++ % ios.size()];
  acceptor.async_accept(io->get_executor(), [this, io](const std::error_code& error, asio::ip::tcp::socket socket) {
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
      std::string limit;
      refusal = connection_problem_locked(address, limit);
      if (!refusal.empty()) refusals.count(limit);
      if (refusal.empty()) {
        detail::LinkConfig config;
        config.limits = hello_limits();
        config.chunk_bytes = options.chunk_bytes;
        config.max_send_queue_bytes = options.max_send_queue_bytes;
        const uint64_t id = next_session_id++;
        auto context = current_tls();
        auto stream = context ? detail::make_tls_stream(std::move(socket), context, /*server=*/true)
                              : detail::make_tcp_stream(std::move(socket));
        session = std::make_shared<ServerSession>(*this, io, id, std::move(stream), config, address);
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

std::string ServerCore::connection_problem_locked(const std::string& address, std::string& limit) const {
  if (sessions.size() >= max_connections) {
    limit = "max_connections";
    return "the server has " + std::to_string(sessions.size()) + " connections open, the limit (max_connections " +
           std::to_string(max_connections) + "); retry later";
  }
  auto it = connections_per_address.find(address);
  const size_t from_address = it == connections_per_address.end() ? 0 : it->second;
  if (from_address >= options.max_connections_per_address) {
    limit = "max_connections_per_address";
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
    session->close(
        Status::UNAUTHENTICATED,
        "credential '" + identity.name + "' was changed or revoked by the operator; reconnect with a current one");
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
    session->close_link(detail::make_goodbye(Status::UNAVAILABLE, "server shutting down"), "server stopped");
  }
  all.clear();
  bool drained = false;
  {
    std::unique_lock<std::mutex> lock(mutex);
    // Each close takes at most the linger time (1 s) to send its Goodbye.
    drained = changed.wait_for(lock, std::chrono::seconds(10), [this] { return sessions.empty(); });
  }
  work.clear();
  if (!drained) {
    spdlog::error("planet: sessions did not close within 10 s; stopping the I/O threads anyway");
    for (const auto& io : ios) io->stop();
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

size_t Server::max_connections() const { return impl_->max_connections; }

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

ServerStats Server::stats() const {
  ServerStats stats;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    stats.connections = impl_->sessions.size();
  }
  stats.sessions = static_cast<size_t>(impl_->session_share->used());
  stats.resumable_sessions = impl_->directory.retained();
  stats.buffered_bytes = impl_->buffer_share->used();
  Refusals refusals;
  for (const auto& [limit, count] : impl_->refusals.snapshot()) refusals.count(limit, count);
  for (const auto* share : {impl_->session_share.get(), impl_->buffer_share.get()}) {
    for (const auto& [limit, count] : share->refusals()) refusals.count(limit, count);
  }
  stats.refusals = refusals.snapshot();
  stats.authentication_failures = impl_->authentication_failures.snapshot();
  stats.protocol_errors = impl_->protocol_errors.snapshot();
  return stats;
}

size_t Server::set_authenticator(std::shared_ptr<const Authenticator> authenticator) {
  return impl_->set_authenticator(std::move(authenticator));
}

}  // namespace urs::planet
