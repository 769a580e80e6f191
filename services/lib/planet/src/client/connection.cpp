#include "client/connection.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <optional>
#include <utility>

#include "link.hpp"
#include "urs/planet/authenticator.hpp"
#include "urs/planet/codec.hpp"

namespace urs::planet::detail {

using std::chrono::milliseconds;

namespace {
constexpr size_t kClientSendQueueBytes = 256ull << 20;
constexpr milliseconds kClientLinger{500};
}  // namespace

// The Link of one connection attempt; what it reads goes to its Connection.
class ClientLink final : public Link, public FrameSink {
 public:
  ClientLink(Connection& connection, std::unique_ptr<Stream> stream, const LinkConfig& config)
      : Link(connection.io_, std::move(stream), config), connection_(connection) {}

  // Strand: the handshake succeeded.
  void open(const Welcome& welcome, const CodecLimits& limits, uint32_t chunk_bytes) {
    set_limits(limits, chunk_bytes);
    mark_open();
    set_heartbeat(milliseconds(0), milliseconds(welcome.heartbeat_timeout_ms()));
  }

  // Strand: why the server ended it, if it said so ("refused: ...", "goodbye: ...").
  std::string explanation;

  // FrameSink
  bool send(Frame&& frame) override { return enqueue(std::move(frame)); }

 protected:
  // Link
  void handle_frame(Frame&& frame) override { connection_.on_link_frame(self(), std::move(frame)); }
  void handle_goodbye(const Goodbye& goodbye) override {
    explanation = "goodbye: " + goodbye.reason();
    spdlog::warn("planet: {} said goodbye ({}): {}", connection_.target_, status_name(goodbye.status()),
                 goodbye.reason());
  }
  void handle_closed(const std::string& reason) override { connection_.on_link_closed(self(), reason); }
  std::string describe() const override { return "connection to " + connection_.target_; }

 private:
  std::shared_ptr<ClientLink> self() { return std::static_pointer_cast<ClientLink>(shared_from_this()); }
  Connection& connection_;
};

Connection::Connection(const ClientOptions& options, std::shared_ptr<asio::io_context> io, SessionListener& listener)
    : options_(options),
      target_(options.host + ":" + std::to_string(options.port)),
      tls_(options.tls.enabled ? make_client_tls_context(options.tls) : nullptr),
      io_(std::move(io)),
      listener_(listener),
      resolver_(*io_),
      reconnect_timer_(*io_),
      connect_timer_(*io_) {}

Connection::~Connection() = default;

bool Connection::connected() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return phase_ == Phase::kOpen;
}

bool Connection::wait_connected(milliseconds timeout) const {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, timeout, [this] { return phase_ == Phase::kOpen || stopped_; }) &&
         phase_ == Phase::kOpen;
}

std::string Connection::last_error() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_error_;
}

Welcome Connection::welcome() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return welcome_;
}

void Connection::start() { start_connect(); }

void Connection::shutdown() {
  std::lock_guard<std::mutex> lock(mutex_);
  stopped_ = true;
  ++generation_;  // ignore completions of an attempt in progress
  reconnect_timer_.cancel();
  connect_timer_.cancel();
  resolver_.cancel();
  if (connecting_) {
    std::error_code ignored;
    connecting_->close(ignored);
    connecting_.reset();
  }
  if (link_) {
    link_->close_link(make_goodbye(Status::OK, "client stopped"), "client stopped");
    link_.reset();
  }
  phase_ = Phase::kIdle;
  changed_.notify_all();
}

// ---- Connecting ---------------------------------------------------------------------------------

void Connection::arm_connect_timer_locked(uint64_t attempt) {
  connect_timer_.expires_after(options_.connect_timeout);
  connect_timer_.async_wait([this, attempt](const std::error_code& error) {
    if (!error) on_connect_timer(attempt);
  });
}

std::string Connection::attempt_failure_locked(const std::string& error) const {
  if (connect_timed_out_) {
    return "connect to " + target_ + " timed out after " + std::to_string(options_.connect_timeout.count()) + " ms";
  }
  return error;
}

void Connection::start_connect() {
  uint64_t attempt = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopped_) return;
    phase_ = Phase::kConnecting;
    attempt = ++generation_;
    connect_timed_out_ = false;
    arm_connect_timer_locked(attempt);
  }
  std::error_code error;
  const asio::ip::address address = asio::ip::make_address(options_.host, error);
  if (!error) {
    connect_to(attempt, {asio::ip::tcp::endpoint(address, options_.port)});
    return;
  }
  resolver_.async_resolve(
      options_.host, std::to_string(options_.port),
      [this, attempt](const std::error_code& resolve_error, asio::ip::tcp::resolver::results_type results) {
        if (resolve_error) {
          std::lock_guard<std::mutex> lock(mutex_);
          if (attempt != generation_ || stopped_) return;
          attempt_failed_locked(
              attempt_failure_locked("cannot resolve " + options_.host + ": " + resolve_error.message()));
          return;
        }
        std::vector<asio::ip::tcp::endpoint> endpoints;
        for (const auto& entry : results) endpoints.push_back(entry.endpoint());
        connect_to(attempt, std::move(endpoints));
      });
}

void Connection::connect_to(uint64_t attempt, std::vector<asio::ip::tcp::endpoint> endpoints) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (attempt != generation_ || stopped_) return;
  connecting_ = std::make_shared<asio::ip::tcp::socket>(asio::make_strand(*io_));
  asio::async_connect(
      *connecting_, endpoints,
      [this, attempt, keep = connecting_](const std::error_code& error, const asio::ip::tcp::endpoint&) {
        on_socket_connected(attempt, error);
      });
}

void Connection::on_socket_connected(uint64_t attempt, const std::error_code& error) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (attempt != generation_ || stopped_) return;
  if (error) {
    connecting_.reset();
    attempt_failed_locked(attempt_failure_locked("cannot connect to " + target_ + ": " + error.message()));
    return;
  }
  LinkConfig config;
  config.limits.max_frame_bytes = options_.chunk_bytes;
  config.limits.max_message_bytes = options_.max_message_bytes;
  config.chunk_bytes = options_.chunk_bytes;
  config.max_send_queue_bytes = kClientSendQueueBytes;
  config.linger = kClientLinger;
  auto stream = tls_ ? make_tls_stream(std::move(*connecting_), tls_, /*server=*/false,
                                       options_.tls.server_name.empty() ? options_.host : options_.tls.server_name)
                     : make_tcp_stream(std::move(*connecting_));
  link_ = std::make_shared<ClientLink>(*this, std::move(stream), config);
  connecting_.reset();
  phase_ = Phase::kHandshaking;
  arm_connect_timer_locked(attempt);  // the handshake gets its own connect_timeout
  Frame hello_frame;
  Hello& hello = *hello_frame.mutable_hello();
  hello.set_version(kProtocolVersion);
  hello.set_token(options_.token);
  hello.set_peer_name(options_.peer_name);
  hello.set_role(options_.role);
  hello.set_session_secret(session_secret_);
  link_->enqueue(hello_frame);
  link_->start();
}

void Connection::on_connect_timer(uint64_t attempt) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (attempt != generation_ || stopped_) return;
  if (phase_ == Phase::kConnecting) {
    connect_timed_out_ = true;
    resolver_.cancel();
    if (connecting_) {
      std::error_code ignored;
      connecting_->close(ignored);
    }
  } else if (phase_ == Phase::kHandshaking && link_) {
    link_->close_link(std::nullopt, "no Welcome from " + target_ + " within " +
                                        std::to_string(options_.connect_timeout.count()) + " ms");
  }
}

void Connection::attempt_failed_locked(const std::string& reason) {
  last_error_ = reason;
  phase_ = Phase::kIdle;
  changed_.notify_all();
  schedule_reconnect_locked();
}

void Connection::schedule_reconnect_locked() {
  if (stopped_) return;
  const auto min = options_.reconnect_min.count();
  const auto max = options_.reconnect_max.count();
  const unsigned doublings = std::min(failures_, 30u);
  const auto base = std::min<int64_t>(max, min << doublings);
  // Jitter within [base/2, base], never below reconnect_min, so that clients that lost the same
  // server do not come back in lockstep.
  std::uniform_int_distribution<int64_t> jitter(base / 2, base);
  const milliseconds delay(std::max<int64_t>(min, jitter(rng_)));
  if (failures_ == 0) {
    spdlog::warn("planet: not connected to {} ({}); retrying in {} ms", target_, last_error_, delay.count());
  } else {
    spdlog::debug("planet: not connected to {} ({}); retrying in {} ms", target_, last_error_, delay.count());
  }
  ++failures_;
  reconnect_timer_.expires_after(delay);
  reconnect_timer_.async_wait([this](const std::error_code& error) {
    if (!error) start_connect();
  });
}

// ---- The session --------------------------------------------------------------------------------

void Connection::on_link_frame(const std::shared_ptr<ClientLink>& from, Frame&& frame) {
  Deferred out;
  bool handshaking = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (from != link_) return;
    handshaking = phase_ == Phase::kHandshaking;
    if (handshaking) on_handshake_frame_locked(from, frame, out);
  }
  if (handshaking) {
    run_all(out);
    return;
  }
  listener_.session_frame(from, std::move(frame));
}

void Connection::on_handshake_frame_locked(const std::shared_ptr<ClientLink>& from, const Frame& frame, Deferred& out) {
  if (frame.has_welcome()) {
    on_welcome_locked(from, frame.welcome(), out);
  } else if (frame.has_refused()) {
    from->explanation = "refused: " + frame.refused().reason();
    spdlog::error("planet: {} refused the connection ({}): {}", target_, status_name(frame.refused().status()),
                  frame.refused().reason());
    from->close_link(std::nullopt, from->explanation);
  } else {
    const std::string reason =
        "expected Welcome or Refused from " + target_ + ", got " + std::string(frame_body_name(frame));
    spdlog::warn("planet: {}", reason);
    from->close_link(make_goodbye(Status::BAD_ARGUMENTS, reason), reason);
  }
}

void Connection::on_welcome_locked(const std::shared_ptr<ClientLink>& from, const Welcome& server_welcome,
                                   Deferred& out) {
  connect_timer_.cancel();
  welcome_ = server_welcome;
  const bool resumed = !session_secret_.empty() && session_secret_ == welcome_.session_secret();
  session_secret_ = welcome_.session_secret();
  welcome_.clear_session_secret();
  failures_ = 0;
  const uint64_t send_limit = welcome_.max_message_bytes() > 0 ? welcome_.max_message_bytes() : UINT64_MAX;
  CodecLimits limits;
  limits.max_message_bytes = options_.max_message_bytes;
  limits.max_frame_bytes =
      std::min<uint64_t>(std::max<uint64_t>(options_.chunk_bytes, welcome_.chunk_bytes()), options_.max_message_bytes);
  const uint32_t chunk_bytes = welcome_.chunk_bytes() >= kMinChunkBytes
                                   ? std::min(options_.chunk_bytes, welcome_.chunk_bytes())
                                   : options_.chunk_bytes;
  from->open(welcome_, limits, chunk_bytes);
  spdlog::info("planet: connected to {} (space '{}', server instance {}) as {} (role {}), {} session", target_,
               welcome_.space(), welcome_.server_instance(), welcome_.identity(), role_word(welcome_.role()),
               resumed ? "resumed" : "new");
  listener_.session_opened(from, welcome_, send_limit, out);
  phase_ = Phase::kOpen;
  changed_.notify_all();
}

void Connection::on_link_closed(const std::shared_ptr<ClientLink>& closed, const std::string& reason) {
  Deferred out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed != link_) return;
    const bool was_open = phase_ == Phase::kOpen;
    link_.reset();
    connect_timer_.cancel();
    ++generation_;
    if (!closed->explanation.empty()) {
      last_error_ = closed->explanation;
    } else if (was_open) {
      last_error_ = reason;
    } else {
      last_error_ = "handshake with " + target_ + " failed: " + reason;
    }
    listener_.session_closed(last_error_, was_open, out);
    phase_ = Phase::kIdle;
    changed_.notify_all();
    if (was_open) failures_ = 0;
    if (!stopped_) schedule_reconnect_locked();
  }
  run_all(out);
}

}  // namespace urs::planet::detail
