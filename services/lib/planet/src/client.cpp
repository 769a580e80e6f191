#include "urs/planet/client.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <future>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <stdexcept>
#include <thread>
#include <vector>

#include "link.hpp"
#include "urs/planet/authenticator.hpp"
#include "urs/planet/codec.hpp"

namespace urs::planet {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

// ---- Responder ----------------------------------------------------------------------------------

struct Responder::State {
  std::function<void(CallResult)> deliver;  // empty for a oneway request: nothing is sent
  std::atomic<bool> answered{false};
};

namespace {

void answer_if_pending(const std::shared_ptr<Responder::State>& state) noexcept {
  if (!state || !state->deliver || state->answered.exchange(true)) return;
  try {
    state->deliver(CallResult::error(Status::INTERNAL, "provider dropped the request"));
  } catch (const std::exception& exception) {
    spdlog::error("planet: answering a dropped request failed: {}", exception.what());
  }
}

}  // namespace

Responder::Responder(std::shared_ptr<State> state) : state_(std::move(state)) {}
Responder::Responder(Responder&&) noexcept = default;
Responder& Responder::operator=(Responder&& other) noexcept {
  if (this != &other) {
    answer_if_pending(state_);
    state_ = std::move(other.state_);
  }
  return *this;
}
Responder::~Responder() { answer_if_pending(state_); }

void Responder::reply(CallResult result) {
  if (!state_ || state_->answered.exchange(true)) return;
  if (state_->deliver) state_->deliver(std::move(result));
}

bool Responder::pending() const {
  return state_ && state_->deliver && !state_->answered.load();
}

Responder Responder::from_callback(std::function<void(CallResult)> fn) {
  auto state = std::make_shared<State>();
  state->deliver = std::move(fn);
  return Responder(std::move(state));
}

// ---- Client -------------------------------------------------------------------------------------

namespace {

using Deferred = std::vector<std::function<void()>>;

void run_all(Deferred& callbacks) {
  for (auto& callback : callbacks) {
    try {
      callback();
    } catch (const std::exception& exception) {
      spdlog::error("planet: client callback threw: {}", exception.what());
    }
  }
  callbacks.clear();
}

// Queues `handler(result)` to run after the client's mutex is released.
void defer_reply(Deferred& out, ReplyHandler handler, CallResult result) {
  out.push_back([handler = std::move(handler), result = std::move(result)]() mutable {
    handler(std::move(result));
  });
}

void validate(const ClientOptions& options) {
  std::vector<std::string> errors;
  auto ms = [](milliseconds value) { return std::to_string(value.count()) + " ms"; };
  if (options.connect_timeout.count() <= 0) {
    errors.push_back("connect_timeout " + ms(options.connect_timeout) + " must be > 0");
  }
  if (options.reconnect_min.count() <= 0 || options.reconnect_max < options.reconnect_min) {
    errors.push_back("reconnect_min " + ms(options.reconnect_min) + " and reconnect_max " +
                     ms(options.reconnect_max) + " must satisfy 0 < min <= max");
  }
  if (options.queue_timeout.count() <= 0) {
    errors.push_back("queue_timeout " + ms(options.queue_timeout) + " must be > 0");
  }
  check_message_limits(options.chunk_bytes, options.max_message_bytes, errors);
  if (errors.empty()) return;
  std::string message = "invalid Planet ClientOptions:";
  for (const auto& error : errors) message += "\n  " + error;
  throw std::invalid_argument(message);
}

constexpr size_t kClientSendQueueBytes = 256ull << 20;
constexpr milliseconds kClientLinger{500};

}  // namespace

class ClientLink;

// Everything the client owns. Client::Impl is this; ClientLink names it ClientCore because
// Client::Impl is private.
struct ClientCore {
  explicit ClientCore(ClientOptions options_in);

  // Public API (any thread).
  void start();
  void stop();
  void call_async(const std::string& service, const std::string& operation, std::string payload,
                  milliseconds deadline, ReplyHandler handler, bool oneway, bool* accepted);
  CallResult publish(const std::string& topic, std::string payload,
                     const std::string& content_type);
  // The same with the lock held; `id` receives the publish id.
  CallResult publish_locked(const std::string& topic, std::string payload, const std::string& content_type,
                            uint64_t& id);
  uint64_t subscribe(const std::string& pattern, EventHandler handler, uint64_t resume_after_seq);
  void unsubscribe(uint64_t subscription_id);
  void register_service(const camus::RegisterRequest& registration, ReplyHandler handler);

  // I/O thread.
  void start_connect();
  void connect_to(uint64_t generation, std::vector<asio::ip::tcp::endpoint> endpoints);
  void on_socket_connected(uint64_t generation, const std::error_code& error);
  void on_connect_timer(uint64_t generation);
  void on_link_frame(const std::shared_ptr<ClientLink>& link, Frame&& frame);
  void on_link_closed(const std::shared_ptr<ClientLink>& link, const std::string& reason);
  void on_deadline(uint64_t call_id);
  void shutdown_on_io();

  // With mutex held.
  struct PendingCall {
    Request request;           // cleared once sent
    std::string label;         // "service.operation"
    ReplyHandler handler;      // empty for oneways
    std::unique_ptr<asio::steady_timer> timer;
    Clock::time_point expires;
    milliseconds deadline{0};  // 0: none given, the server's applies once sent
    bool sent = false;
  };
  struct Subscription {
    std::string pattern;
    std::shared_ptr<EventHandler> handler;
    uint64_t last_seq = 0;
  };
  struct Registration {
    camus::RegisterRequest request;
    ReplyHandler first_handler;  // result of the first attempt; then re-registrations only log
  };

  size_t queued_locked() const { return queue.size() + unacked.size(); }
  std::string queue_full_message_locked() const;
  // Registers a call; sends it now if connected and nothing is queued before it (or if
  // `jump_queue`), else queues it.
  uint64_t start_call_locked(Request request, milliseconds deadline, ReplyHandler handler,
                             Deferred& out, bool jump_queue = false);
  bool send_call_locked(uint64_t call_id, Deferred& out);
  bool send_publish_locked(const Publish& publish);
  void send_subscribe_locked(uint64_t id, const Subscription& subscription);
  void on_welcome_locked(const std::shared_ptr<ClientLink>& link, const Welcome& welcome,
                         Deferred& out);
  void attempt_failed_locked(const std::string& reason);
  void schedule_reconnect_locked();
  void fail_all_locked(const std::string& message, Deferred& out);
  bool on_io_thread() const { return std::this_thread::get_id() == io_thread_id.load(); }
  // With the mutex held: hands `callbacks` to the I/O thread if it runs and this is another
  // thread (posting under the mutex guarantees the thread runs them before stop() joins it).
  // What is left in `callbacks` the caller runs itself after unlocking.
  void post_locked(Deferred& callbacks);

  const ClientOptions options;
  const std::string target;  // "host:port"
  // Null: plain TCP. Built once (the CA and client certificate are read at construction).
  const std::shared_ptr<asio::ssl::context> tls =
      options.tls.enabled ? detail::make_client_tls_context(options.tls) : nullptr;
  std::shared_ptr<asio::io_context> io = std::make_shared<asio::io_context>();
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work;
  std::thread thread;
  std::atomic<std::thread::id> io_thread_id{};

  // I/O thread only.
  asio::ip::tcp::resolver resolver{*io};
  std::shared_ptr<asio::ip::tcp::socket> connecting;

  // Set before start(), read-only afterwards.
  RequestHandler request_handler;
  std::function<void(const Welcome&)> connected_handler;
  std::function<void(const std::string&)> disconnected_handler;

  mutable std::mutex mutex;
  mutable std::condition_variable changed;
  enum class Phase { kIdle, kConnecting, kHandshaking, kOpen };
  Phase phase = Phase::kIdle;
  bool started = false;
  bool stopping = false;
  bool stopped = false;
  uint64_t generation = 0;  // of the current connection attempt
  bool connect_timed_out = false;
  asio::steady_timer reconnect_timer{*io};
  asio::steady_timer connect_timer{*io};
  std::shared_ptr<ClientLink> link;
  Welcome welcome;             // of the current (or last) session, its session_secret cleared
  std::string session_secret;  // the server's, presented in the next Hello; never logged
  std::string last_error;
  unsigned failures = 0;  // consecutive failed attempts, for the backoff
  std::mt19937_64 rng{std::random_device{}()};
  uint64_t send_limit = UINT64_MAX;  // the server's max_message_bytes

  uint64_t next_call_id = 1;
  std::map<uint64_t, PendingCall> calls;  // waiting for a reply, and queued (incl. oneways)
  std::deque<uint64_t> queue;             // call ids not yet sent, in order
  uint64_t next_publish_id = 1;
  std::map<uint64_t, Publish> unacked;    // by publish_id: resent in order after a reconnect
  std::map<uint64_t, PublishAck> awaited; // acks of publishes a publish_and_wait() waits for
  uint64_t next_subscription_id = 1;
  std::map<uint64_t, Subscription> subscriptions;
  uint64_t delivering = 0;  // the subscription whose handler runs now on the I/O thread, or 0
  std::vector<Registration> registrations;
};

class ClientLink final : public detail::Link {
 public:
  ClientLink(ClientCore& impl, std::unique_ptr<detail::Stream> stream, const detail::LinkConfig& config)
      : Link(impl.io, std::move(stream), config), impl_(impl) {}

  // Strand: the handshake succeeded.
  void open(const Welcome& welcome, const CodecLimits& limits, uint32_t chunk_bytes) {
    set_limits(limits, chunk_bytes);
    mark_open();
    set_heartbeat(milliseconds(0), milliseconds(welcome.heartbeat_timeout_ms()));
  }

  // Strand: why the server ended it, if it said so ("refused: ...", "goodbye: ...").
  std::string explanation;

 protected:
  // Link
  void handle_frame(Frame&& frame) override { impl_.on_link_frame(self(), std::move(frame)); }
  void handle_goodbye(const Goodbye& goodbye) override {
    explanation = "goodbye: " + goodbye.reason();
    spdlog::warn("planet: {} said goodbye ({}): {}", impl_.target, status_name(goodbye.status()),
                 goodbye.reason());
  }
  void handle_closed(const std::string& reason) override { impl_.on_link_closed(self(), reason); }
  std::string describe() const override { return "connection to " + impl_.target; }

 private:
  std::shared_ptr<ClientLink> self() {
    return std::static_pointer_cast<ClientLink>(shared_from_this());
  }
  ClientCore& impl_;
};

ClientCore::ClientCore(ClientOptions options_in)
    : options(std::move(options_in)),
      target(options.host + ":" + std::to_string(options.port)) {
  validate(options);
  request_handler = [](const Request& request, Responder responder) {
    responder.reply(CallResult::error(
        Status::UNKNOWN_SERVICE,
        "no request handler on this client for service '" + request.service() + "'"));
  };
}

void ClientCore::post_locked(Deferred& callbacks) {
  if (callbacks.empty() || !started || stopping || on_io_thread()) return;
  asio::post(*io, [callbacks = std::move(callbacks)]() mutable { run_all(callbacks); });
  callbacks = Deferred();
}

void ClientCore::start() {
  std::lock_guard<std::mutex> lock(mutex);  // the thread body does not take it
  if (started || stopping) return;
  started = true;
  work.emplace(io->get_executor());
  thread = std::thread([this] {
    io_thread_id.store(std::this_thread::get_id());
    for (;;) {
      try {
        io->run();
        return;
      } catch (const std::exception& exception) {
        spdlog::error("planet: client I/O thread caught: {}", exception.what());
      }
    }
  });
  asio::post(*io, [this] { start_connect(); });
}

void ClientCore::stop() {
  bool was_started = false;
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (stopping) return;
    if (started && on_io_thread()) {
      throw std::logic_error("planet::Client::stop() called from a callback on its I/O thread");
    }
    stopping = true;
    was_started = started;
  }
  if (was_started) {
    asio::post(*io, [this] { shutdown_on_io(); });
    work.reset();
    thread.join();
  } else {
    Deferred out;
    {
      std::lock_guard<std::mutex> lock(mutex);
      fail_all_locked("client stopped", out);
    }
    run_all(out);
  }
  std::lock_guard<std::mutex> lock(mutex);
  stopped = true;
  changed.notify_all();
}

void ClientCore::shutdown_on_io() {
  Deferred out;
  {
    std::lock_guard<std::mutex> lock(mutex);
    fail_all_locked("client stopped", out);
    if (!unacked.empty()) {
      spdlog::warn("planet: client stopped with {} unacknowledged publishes; they are dropped",
                   unacked.size());
    }
    unacked.clear();
    ++generation;  // ignore completions of an attempt in progress
    reconnect_timer.cancel();
    connect_timer.cancel();
    resolver.cancel();
    if (connecting) {
      std::error_code ignored;
      connecting->close(ignored);
      connecting.reset();
    }
    if (link) {
      link->close_link(detail::make_goodbye(Status::OK, "client stopped"), "client stopped");
      link.reset();
    }
    phase = Phase::kIdle;
    changed.notify_all();
  }
  run_all(out);
}

void ClientCore::fail_all_locked(const std::string& message, Deferred& out) {
  for (auto& [id, call] : calls) {
    if (call.timer) call.timer->cancel();
    if (call.handler) {
      out.push_back([handler = std::move(call.handler), message] {
        handler(CallResult::error(Status::UNAVAILABLE, message));
      });
    }
  }
  calls.clear();
  queue.clear();
  for (auto& registration : registrations) {
    if (registration.first_handler) {
      out.push_back([handler = std::move(registration.first_handler), message] {
        handler(CallResult::error(Status::UNAVAILABLE, message));
      });
      registration.first_handler = nullptr;
    }
  }
}

std::string ClientCore::queue_full_message_locked() const {
  if (phase == Phase::kOpen) {
    return "the queue of " + std::to_string(options.max_queued) +
           " publishes awaiting acknowledgement from " + target + " is full";
  }
  return "not connected to " + target + " and the queue of " + std::to_string(options.max_queued) +
         " is full";
}

// ---- Connection management (I/O thread) ---------------------------------------------------------

void ClientCore::start_connect() {
  uint64_t attempt = 0;
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (stopping) return;
    phase = Phase::kConnecting;
    attempt = ++generation;
    connect_timed_out = false;
    connect_timer.expires_after(options.connect_timeout);
    connect_timer.async_wait([this, attempt](const std::error_code& error) {
      if (!error) on_connect_timer(attempt);
    });
  }
  std::error_code error;
  const asio::ip::address address = asio::ip::make_address(options.host, error);
  if (!error) {
    connect_to(attempt, {asio::ip::tcp::endpoint(address, options.port)});
    return;
  }
  resolver.async_resolve(
      options.host, std::to_string(options.port),
      [this, attempt](const std::error_code& resolve_error,
                      asio::ip::tcp::resolver::results_type results) {
        if (resolve_error) {
          std::lock_guard<std::mutex> lock(mutex);
          if (attempt != generation || stopping) return;
          attempt_failed_locked(connect_timed_out
                                    ? "connect to " + target + " timed out after " +
                                          std::to_string(options.connect_timeout.count()) + " ms"
                                    : "cannot resolve " + options.host + ": " +
                                          resolve_error.message());
          return;
        }
        std::vector<asio::ip::tcp::endpoint> endpoints;
        for (const auto& entry : results) endpoints.push_back(entry.endpoint());
        connect_to(attempt, std::move(endpoints));
      });
}

void ClientCore::connect_to(uint64_t attempt, std::vector<asio::ip::tcp::endpoint> endpoints) {
  std::lock_guard<std::mutex> lock(mutex);
  if (attempt != generation || stopping) return;
  connecting = std::make_shared<asio::ip::tcp::socket>(asio::make_strand(*io));
  asio::async_connect(*connecting, endpoints,
                      [this, attempt, keep = connecting](const std::error_code& error,
                                                         const asio::ip::tcp::endpoint&) {
                        on_socket_connected(attempt, error);
                      });
}

void ClientCore::on_socket_connected(uint64_t attempt, const std::error_code& error) {
  std::lock_guard<std::mutex> lock(mutex);
  if (attempt != generation || stopping) return;
  if (error) {
    connecting.reset();
    attempt_failed_locked(connect_timed_out ? "connect to " + target + " timed out after " +
                                                  std::to_string(options.connect_timeout.count()) +
                                                  " ms"
                                            : "cannot connect to " + target + ": " +
                                                  error.message());
    return;
  }
  detail::LinkConfig config;
  config.limits.max_frame_bytes = options.chunk_bytes;
  config.limits.max_message_bytes = options.max_message_bytes;
  config.chunk_bytes = options.chunk_bytes;
  config.max_send_queue_bytes = kClientSendQueueBytes;
  config.linger = kClientLinger;
  auto stream = tls ? detail::make_tls_stream(std::move(*connecting), tls, /*server=*/false,
                                              options.tls.server_name.empty() ? options.host
                                                                              : options.tls.server_name)
                    : detail::make_tcp_stream(std::move(*connecting));
  link = std::make_shared<ClientLink>(*this, std::move(stream), config);
  connecting.reset();
  phase = Phase::kHandshaking;
  // The handshake gets its own connect_timeout.
  connect_timer.expires_after(options.connect_timeout);
  connect_timer.async_wait([this, attempt](const std::error_code& timer_error) {
    if (!timer_error) on_connect_timer(attempt);
  });
  Frame hello_frame;
  Hello& hello = *hello_frame.mutable_hello();
  hello.set_version(kProtocolVersion);
  hello.set_token(options.token);
  hello.set_peer_name(options.peer_name);
  hello.set_role(options.role);
  hello.set_session_secret(session_secret);
  link->enqueue(hello_frame);
  link->start();
}

void ClientCore::on_connect_timer(uint64_t attempt) {
  std::lock_guard<std::mutex> lock(mutex);
  if (attempt != generation || stopping) return;
  const std::string timeout = std::to_string(options.connect_timeout.count()) + " ms";
  if (phase == Phase::kConnecting) {
    connect_timed_out = true;
    resolver.cancel();
    if (connecting) {
      std::error_code ignored;
      connecting->close(ignored);
    }
  } else if (phase == Phase::kHandshaking && link) {
    link->close_link(std::nullopt, "no Welcome from " + target + " within " + timeout);
  }
}

void ClientCore::attempt_failed_locked(const std::string& reason) {
  last_error = reason;
  phase = Phase::kIdle;
  changed.notify_all();
  schedule_reconnect_locked();
}

void ClientCore::schedule_reconnect_locked() {
  if (stopping) return;
  const auto min = options.reconnect_min.count();
  const auto max = options.reconnect_max.count();
  const unsigned doublings = std::min(failures, 30u);
  const auto base = std::min<int64_t>(max, min << doublings);
  // Jitter within [base/2, base], never below reconnect_min, so that clients that lost the same
  // server do not come back in lockstep.
  std::uniform_int_distribution<int64_t> jitter(base / 2, base);
  const milliseconds delay(std::max<int64_t>(min, jitter(rng)));
  if (failures == 0) {
    spdlog::warn("planet: not connected to {} ({}); retrying in {} ms", target, last_error,
                 delay.count());
  } else {
    spdlog::debug("planet: not connected to {} ({}); retrying in {} ms", target, last_error,
                  delay.count());
  }
  ++failures;
  reconnect_timer.expires_after(delay);
  reconnect_timer.async_wait([this](const std::error_code& error) {
    if (!error) start_connect();
  });
}

void ClientCore::on_link_closed(const std::shared_ptr<ClientLink>& closed,
                                  const std::string& reason) {
  Deferred out;
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (closed != link) return;
    const bool was_open = phase == Phase::kOpen;
    link.reset();
    connect_timer.cancel();
    ++generation;
    if (!closed->explanation.empty()) {
      last_error = closed->explanation;
    } else if (was_open) {
      last_error = reason;
    } else {
      last_error = "handshake with " + target + " failed: " + reason;
    }
    // At most once: what may have reached the server is never resent.
    for (auto it = calls.begin(); it != calls.end();) {
      if (!it->second.sent) {
        ++it;
        continue;
      }
      if (it->second.timer) it->second.timer->cancel();
      if (it->second.handler) {
        out.push_back([handler = std::move(it->second.handler)] {
          handler(CallResult::error(Status::UNAVAILABLE, "connection to server lost"));
        });
      }
      it = calls.erase(it);
    }
    phase = Phase::kIdle;
    changed.notify_all();
    if (was_open) {
      failures = 0;
      if (disconnected_handler) {
        out.push_back([handler = disconnected_handler, reason = last_error] { handler(reason); });
      }
    }
    if (!stopping) schedule_reconnect_locked();
  }
  run_all(out);
}

// ---- Frames from the server (I/O thread) --------------------------------------------------------

void ClientCore::on_link_frame(const std::shared_ptr<ClientLink>& from, Frame&& frame) {
  Deferred out;
  std::unique_lock<std::mutex> lock(mutex);
  if (from != link) return;
  if (phase == Phase::kHandshaking) {
    if (frame.has_welcome()) {
      on_welcome_locked(from, frame.welcome(), out);
    } else if (frame.has_refused()) {
      from->explanation = "refused: " + frame.refused().reason();
      spdlog::error("planet: {} refused the connection ({}): {}", target,
                    status_name(frame.refused().status()), frame.refused().reason());
      from->close_link(std::nullopt, from->explanation);
    } else {
      const std::string reason = "expected Welcome or Refused from " + target + ", got " +
                                 std::string(frame_body_name(frame));
      spdlog::warn("planet: {}", reason);
      from->close_link(detail::make_goodbye(Status::BAD_ARGUMENTS, reason), reason);
    }
    lock.unlock();
    run_all(out);
    return;
  }

  switch (frame.body_case()) {
    case Frame::kReply: {
      Reply& reply = *frame.mutable_reply();
      auto it = calls.find(reply.call_id());
      if (it == calls.end() || !it->second.sent) {
        spdlog::debug("planet: ignoring reply to call {} (late or unknown)", reply.call_id());
        break;
      }
      if (it->second.timer) it->second.timer->cancel();
      ReplyHandler handler = std::move(it->second.handler);
      calls.erase(it);
      if (handler) {
        CallResult result;
        result.status = reply.status();
        result.message = std::move(*reply.mutable_message());
        result.payload = std::move(*reply.mutable_payload());
        result.exception_type = std::move(*reply.mutable_exception_type());
        defer_reply(out, std::move(handler), std::move(result));
      }
      break;
    }
    case Frame::kEvent: {
      const Event& event = frame.event();
      auto it = subscriptions.find(event.subscription_id());
      if (it == subscriptions.end()) break;          // unsubscribed meanwhile
      if (event.seq() <= it->second.last_seq) break;  // duplicate (replayed after a resume)
      it->second.last_seq = event.seq();
      auto handler = it->second.handler;
      delivering = event.subscription_id();  // unsubscribe() waits for it
      lock.unlock();
      if (handler && *handler) {
        try {
          (*handler)(event);
        } catch (const std::exception& exception) {
          spdlog::error("planet: event handler for '{}' threw: {}", event.topic(),
                        exception.what());
        }
      }
      lock.lock();
      delivering = 0;
      lock.unlock();
      changed.notify_all();
      return;
    }
    case Frame::kRequest: {
      auto state = std::make_shared<Responder::State>();
      if (!frame.request().oneway()) {
        std::weak_ptr<ClientLink> weak = from;
        state->deliver = [weak, call_id = frame.request().call_id()](CallResult result) {
          auto strong = weak.lock();
          if (!strong) return;  // that connection is gone; the caller gets PROVIDER_GONE
          Frame reply_frame;
          Reply& reply = *reply_frame.mutable_reply();
          reply.set_call_id(call_id);
          reply.set_status(result.status);
          reply.set_message(std::move(result.message));
          reply.set_payload(std::move(result.payload));
          reply.set_exception_type(std::move(result.exception_type));
          strong->enqueue(std::move(reply_frame));
        };
      }
      lock.unlock();
      try {
        request_handler(frame.request(), Responder(std::move(state)));
      } catch (const std::exception& exception) {
        spdlog::error("planet: request handler for {}.{} threw: {}", frame.request().service(),
                      frame.request().operation(), exception.what());
      }
      return;
    }
    case Frame::kPublishAck: {
      const PublishAck& ack = frame.publish_ack();
      auto it = unacked.find(ack.publish_id());
      if (it == unacked.end()) break;  // a duplicate ack after a resend
      if (ack.status() != Status::OK) {
        spdlog::warn("planet: server refused publish {} on '{}': {}: {}", ack.publish_id(),
                     it->second.topic(), status_name(ack.status()), ack.message());
      }
      unacked.erase(it);
      if (auto waiter = awaited.find(ack.publish_id()); waiter != awaited.end()) {
        waiter->second = ack;
        changed.notify_all();
      }
      break;
    }
    case Frame::kSubscribeAck: {
      const SubscribeAck& ack = frame.subscribe_ack();
      auto it = subscriptions.find(ack.subscription_id());
      if (it == subscriptions.end()) break;
      Subscription& subscription = it->second;
      if (ack.status() != Status::OK) {
        spdlog::error("planet: subscription to '{}' refused: {}: {}", subscription.pattern,
                      status_name(ack.status()), ack.message());
        break;
      }
      if (subscription.last_seq > 0 && ack.oldest_retained_seq() > subscription.last_seq + 1) {
        spdlog::warn("planet: events {}..{} on '{}' are no longer retained by {}; they are lost",
                     subscription.last_seq + 1, ack.oldest_retained_seq() - 1,
                     subscription.pattern, target);
      }
      if (subscription.last_seq == 0) {
        // "Only new events": resume after what was current when subscribing.
        subscription.last_seq = ack.last_seq();
      } else if (ack.last_seq() < subscription.last_seq) {
        spdlog::warn("planet: {} restarted its event sequence (now {}, had {}); resuming there",
                     target, ack.last_seq(), subscription.last_seq);
        subscription.last_seq = ack.last_seq();
      }
      break;
    }
    default:
      spdlog::debug("planet: ignoring unexpected {} frame from {}", frame_body_name(frame), target);
      break;
  }
  lock.unlock();
  run_all(out);
}

void ClientCore::on_welcome_locked(const std::shared_ptr<ClientLink>& from,
                                     const Welcome& server_welcome, Deferred& out) {
  connect_timer.cancel();
  welcome = server_welcome;
  const bool resumed = !session_secret.empty() && session_secret == welcome.session_secret();
  session_secret = welcome.session_secret();
  welcome.clear_session_secret();
  phase = Phase::kOpen;
  failures = 0;
  send_limit = welcome.max_message_bytes() > 0 ? welcome.max_message_bytes() : UINT64_MAX;
  CodecLimits limits;
  limits.max_message_bytes = options.max_message_bytes;
  limits.max_frame_bytes =
      std::min<uint64_t>(std::max<uint64_t>(options.chunk_bytes, welcome.chunk_bytes()),
                         options.max_message_bytes);
  const uint32_t chunk_bytes =
      welcome.chunk_bytes() >= kMinChunkBytes
          ? std::min(options.chunk_bytes, welcome.chunk_bytes())
          : options.chunk_bytes;
  from->open(welcome, limits, chunk_bytes);
  spdlog::info("planet: connected to {} (space '{}', server instance {}) as {} (role {}), {} session",
               target, welcome.space(), welcome.server_instance(), welcome.identity(),
               role_word(welcome.role()), resumed ? "resumed" : "new");

  // Restore, in this order: registrations, subscriptions, unacknowledged publishes, queued calls.
  for (Registration& registration : registrations) {
    Request request;
    request.set_service("camus.registry");
    request.set_operation("Register");
    request.set_payload(registration.request.SerializeAsString());
    ReplyHandler handler = std::move(registration.first_handler);
    registration.first_handler = nullptr;
    if (!handler) {
      handler = [name = registration.request.service().name()](CallResult result) {
        if (!result.ok()) {
          spdlog::error("planet: re-registering service '{}' failed: {}: {}", name,
                        status_name(result.status), result.message);
        }
      };
    }
    start_call_locked(std::move(request), milliseconds(0), std::move(handler), out,
                      /*jump_queue=*/true);
  }
  for (const auto& [id, subscription] : subscriptions) send_subscribe_locked(id, subscription);
  for (auto it = unacked.begin(); it != unacked.end();) {
    if (it->second.ByteSizeLong() + 16 > send_limit) {
      spdlog::error("planet: dropping publish {} on '{}': {} bytes exceed the server's "
                    "max_message_bytes {}",
                    it->first, it->second.topic(), it->second.ByteSizeLong(), send_limit);
      it = unacked.erase(it);
      continue;
    }
    send_publish_locked(it->second);
    ++it;
  }
  while (!queue.empty() && phase == Phase::kOpen) {
    if (!send_call_locked(queue.front(), out)) break;
    queue.pop_front();
  }
  changed.notify_all();
  if (connected_handler) {
    out.push_back([handler = connected_handler, copy = welcome] { handler(copy); });
  }
}

// ---- Calls --------------------------------------------------------------------------------------

uint64_t ClientCore::start_call_locked(Request request, milliseconds deadline,
                                         ReplyHandler handler, Deferred& out, bool jump_queue) {
  const uint64_t id = next_call_id++;
  request.set_call_id(id);
  PendingCall call;
  call.label = request.service() + "." + request.operation();
  call.handler = std::move(handler);
  call.deadline = deadline;
  // Without a deadline the local timer bounds only the wait for a connection: once sent, the
  // server answers by the service's deadline (docs/planet.md, "Calls and deadlines").
  call.expires = Clock::now() + (deadline.count() > 0 ? deadline : options.queue_timeout);
  const bool oneway = request.oneway();
  call.request = std::move(request);
  if (!oneway) {
    call.timer = std::make_unique<asio::steady_timer>(*io);
    call.timer->expires_at(call.expires);
    call.timer->async_wait([this, id](const std::error_code& error) {
      if (!error) on_deadline(id);
    });
  }
  calls.emplace(id, std::move(call));
  if (phase == Phase::kOpen && (queue.empty() || jump_queue) && send_call_locked(id, out)) {
    return id;
  }
  queue.push_back(id);
  return id;
}

bool ClientCore::send_call_locked(uint64_t id, Deferred& out) {
  auto it = calls.find(id);
  if (it == calls.end()) return true;  // expired while queued
  PendingCall& call = it->second;
  Frame frame;
  Request& request = *frame.mutable_request();
  request = std::move(call.request);
  if (request.oneway() || call.deadline.count() == 0) {
    request.set_deadline_ms(0);  // the service's deadline, else the server's default
  } else {
    const auto left = std::chrono::duration_cast<milliseconds>(call.expires - Clock::now()).count();
    request.set_deadline_ms(static_cast<uint32_t>(std::max<int64_t>(1, left)));
  }
  const size_t size = frame.ByteSizeLong();
  if (size > send_limit) {
    const std::string message = "request of " + std::to_string(size) + " bytes to " + call.label +
                                " exceeds the server's max_message_bytes " +
                                std::to_string(send_limit);
    spdlog::warn("planet: {}", message);
    if (call.timer) call.timer->cancel();
    if (call.handler) {
      out.push_back([handler = std::move(call.handler), message] {
        handler(CallResult::error(Status::PAYLOAD_TOO_LARGE, message));
      });
    }
    calls.erase(it);
    return true;
  }
  const bool oneway = request.oneway();
  if (!link || !link->enqueue(std::move(frame))) {
    // The connection is closing (enqueue left the frame as it was): keep it for the next one.
    call.request = std::move(*frame.mutable_request());
    return false;
  }
  if (oneway) {
    calls.erase(it);
  } else {
    call.sent = true;
  }
  return true;
}

void ClientCore::on_deadline(uint64_t id) {
  ReplyHandler handler;
  Status status = Status::DEADLINE_EXCEEDED;
  std::string message;
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = calls.find(id);
    if (it == calls.end()) return;
    const bool server_deadline = it->second.deadline.count() == 0;
    if (server_deadline && it->second.sent) return;  // the server's answer bounds it now
    if (!it->second.sent) queue.erase(std::remove(queue.begin(), queue.end(), id), queue.end());
    handler = std::move(it->second.handler);
    if (server_deadline) {
      status = Status::UNAVAILABLE;
      message = it->second.label + " not sent: no connection to " + target + " within " +
                std::to_string(options.queue_timeout.count()) + " ms";
    } else {
      message = "no reply from " + it->second.label + " within " +
                std::to_string(it->second.deadline.count()) + " ms";
    }
    calls.erase(it);
  }
  if (!handler) return;
  try {
    handler(CallResult::error(status, message));
  } catch (const std::exception& exception) {
    spdlog::error("planet: reply handler threw: {}", exception.what());
  }
}

void ClientCore::call_async(const std::string& service, const std::string& operation,
                              std::string payload, milliseconds deadline, ReplyHandler handler,
                              bool oneway, bool* accepted) {
  Deferred out;
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (stopping) {
      if (handler) {
        defer_reply(out, std::move(handler), CallResult::error(Status::UNAVAILABLE, "client stopped"));
      }
      if (accepted) *accepted = false;
    } else if (phase != Phase::kOpen && queued_locked() >= options.max_queued) {
      const std::string message = queue_full_message_locked();
      if (handler) {
        defer_reply(out, std::move(handler), CallResult::error(Status::UNAVAILABLE, message));
      } else {
        spdlog::warn("planet: dropping oneway {}.{}: {}", service, operation, message);
      }
      if (accepted) *accepted = false;
    } else {
      Request request;
      request.set_service(service);
      request.set_operation(operation);
      request.set_payload(std::move(payload));
      request.set_oneway(oneway);
      start_call_locked(std::move(request), std::max(deadline, milliseconds(0)),
                        std::move(handler), out);
      if (accepted) *accepted = true;
    }
    post_locked(out);
  }
  run_all(out);
}

// ---- Events -------------------------------------------------------------------------------------

bool ClientCore::send_publish_locked(const Publish& publish) {
  Frame frame;
  *frame.mutable_publish() = publish;
  return link && link->enqueue(frame);
}

void ClientCore::send_subscribe_locked(uint64_t id, const Subscription& subscription) {
  Frame frame;
  Subscribe& subscribe = *frame.mutable_subscribe();
  subscribe.set_subscription_id(id);
  subscribe.set_pattern(subscription.pattern);
  subscribe.set_resume_after_seq(subscription.last_seq);
  if (link) link->enqueue(frame);
}

CallResult ClientCore::publish(const std::string& topic, std::string payload,
                                 const std::string& content_type) {
  std::lock_guard<std::mutex> lock(mutex);
  uint64_t id = 0;
  return publish_locked(topic, std::move(payload), content_type, id);
}

CallResult ClientCore::publish_locked(const std::string& topic, std::string payload, const std::string& content_type,
                                      uint64_t& id) {
  if (stopping) return CallResult::error(Status::UNAVAILABLE, "client stopped");
  if (queued_locked() >= options.max_queued) {
    return CallResult::error(Status::UNAVAILABLE, queue_full_message_locked());
  }
  Publish publish;
  publish.set_publish_id(next_publish_id++);
  publish.set_topic(topic);
  publish.set_payload(std::move(payload));
  publish.set_content_type(content_type);
  if (phase == Phase::kOpen) {
    const size_t size = publish.ByteSizeLong() + 16;
    if (size > send_limit) {
      return CallResult::error(Status::PAYLOAD_TOO_LARGE,
                               "publish of " + std::to_string(size) + " bytes on '" + topic +
                                   "' exceeds the server's max_message_bytes " +
                                   std::to_string(send_limit));
    }
    send_publish_locked(publish);
  }
  id = publish.publish_id();
  unacked.emplace(publish.publish_id(), std::move(publish));
  return CallResult::success({});
}

uint64_t ClientCore::subscribe(const std::string& pattern, EventHandler handler,
                                 uint64_t resume_after_seq) {
  std::lock_guard<std::mutex> lock(mutex);
  const uint64_t id = next_subscription_id++;
  Subscription subscription;
  subscription.pattern = pattern;
  subscription.handler = std::make_shared<EventHandler>(std::move(handler));
  subscription.last_seq = resume_after_seq;
  if (phase == Phase::kOpen) send_subscribe_locked(id, subscription);
  subscriptions.emplace(id, std::move(subscription));
  return id;
}

void ClientCore::unsubscribe(uint64_t subscription_id) {
  std::unique_lock<std::mutex> lock(mutex);
  if (subscriptions.erase(subscription_id) == 0) return;
  if (phase == Phase::kOpen && link) {
    Frame frame;
    frame.mutable_unsubscribe()->set_subscription_id(subscription_id);
    link->enqueue(frame);
  }
  // The handler may be running on the I/O thread: once this returns, it runs no more, so what it
  // uses may be destroyed. From the handler itself (the I/O thread) there is nothing to wait for.
  if (!on_io_thread()) changed.wait(lock, [&] { return delivering != subscription_id; });
}

void ClientCore::register_service(const camus::RegisterRequest& registration,
                                    ReplyHandler handler) {
  Deferred out;
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (stopping) {
      if (handler) {
        defer_reply(out, std::move(handler), CallResult::error(Status::UNAVAILABLE, "client stopped"));
      }
    } else {
      const std::string& name = registration.service().name();
      auto it = std::find_if(
          registrations.begin(), registrations.end(),
          [&](const Registration& r) { return r.request.service().name() == name; });
      if (it == registrations.end()) {
        registrations.push_back({registration, nullptr});
        it = registrations.end() - 1;
      } else {
        it->request = registration;
      }
      if (phase == Phase::kOpen) {
        Request request;
        request.set_service("camus.registry");
        request.set_operation("Register");
        request.set_payload(registration.SerializeAsString());
        if (!handler) {
          handler = [name](CallResult result) {
            if (!result.ok()) {
              spdlog::error("planet: registering service '{}' failed: {}: {}", name,
                            status_name(result.status), result.message);
            }
          };
        }
        start_call_locked(std::move(request), milliseconds(0), std::move(handler), out);
      } else {
        // Sent first thing on the next session; the handler gets that attempt's result.
        it->first_handler = std::move(handler);
      }
    }
    post_locked(out);
  }
  run_all(out);
}

// ---- Client façade -----------------------------------------------------------------------------

struct Client::Impl : ClientCore {
  using ClientCore::ClientCore;
};

Client::Client(ClientOptions options) : impl_(std::make_shared<Impl>(std::move(options))) {}

Client::~Client() { stop(); }

void Client::set_request_handler(RequestHandler handler) {
  if (handler) impl_->request_handler = std::move(handler);
}

void Client::on_connected(std::function<void(const Welcome&)> handler) {
  impl_->connected_handler = std::move(handler);
}

void Client::on_disconnected(std::function<void(const std::string& reason)> handler) {
  impl_->disconnected_handler = std::move(handler);
}

void Client::start() { impl_->start(); }

void Client::stop() { impl_->stop(); }

bool Client::connected() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->phase == Impl::Phase::kOpen;
}

bool Client::wait_connected(std::chrono::milliseconds timeout) const {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  return impl_->changed.wait_for(lock, timeout, [this] {
    return impl_->phase == Impl::Phase::kOpen || impl_->stopped;
  }) && impl_->phase == Impl::Phase::kOpen;
}

std::string Client::last_error() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->last_error;
}

Welcome Client::welcome() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->welcome;
}

void Client::call_async(const std::string& service, const std::string& operation,
                        std::string payload, std::chrono::milliseconds deadline,
                        ReplyHandler handler) {
  impl_->call_async(service, operation, std::move(payload), deadline, std::move(handler), false,
                    nullptr);
}

CallResult Client::call(const std::string& service, const std::string& operation,
                        std::string payload, std::chrono::milliseconds deadline) {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    if (impl_->started && impl_->on_io_thread()) {
      return CallResult::error(Status::INTERNAL,
                               "Client::call() would block the client's I/O thread; use "
                               "call_async() from callbacks");
    }
    if (!impl_->started && !impl_->stopping) {
      return CallResult::error(Status::UNAVAILABLE, "client not started: call start() first");
    }
  }
  auto promise = std::make_shared<std::promise<CallResult>>();
  auto future = promise->get_future();
  impl_->call_async(service, operation, std::move(payload), deadline,
                    [promise](CallResult result) { promise->set_value(std::move(result)); },
                    false, nullptr);
  return future.get();
}

bool Client::oneway(const std::string& service, const std::string& operation,
                    std::string payload) {
  bool accepted = false;
  impl_->call_async(service, operation, std::move(payload), std::chrono::milliseconds(0), {},
                    true, &accepted);
  return accepted;
}

CallResult Client::publish(const std::string& topic, std::string payload,
                           const std::string& content_type) {
  return impl_->publish(topic, std::move(payload), content_type);
}

CallResult Client::publish_and_wait(const std::string& topic, std::string payload, const std::string& content_type,
                                    std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  uint64_t id = 0;
  CallResult queued = impl_->publish_locked(topic, std::move(payload), content_type, id);
  if (!queued.ok()) return queued;
  // Registered under the same lock as the publish: the ack, handled on the I/O thread under it
  // too, cannot come before.
  impl_->awaited.emplace(id, PublishAck());
  const bool acked = impl_->changed.wait_for(lock, timeout, [&] {
    return impl_->awaited.at(id).publish_id() == id || impl_->stopped;
  });
  const PublishAck ack = impl_->awaited.at(id);
  impl_->awaited.erase(id);
  if (!acked || ack.publish_id() != id) {
    return CallResult::error(impl_->stopped ? Status::UNAVAILABLE : Status::DEADLINE_EXCEEDED,
                             "no acknowledgement of the event on '" + topic + "' within " +
                                 std::to_string(timeout.count()) + " ms");
  }
  if (ack.status() != Status::OK) return CallResult::error(ack.status(), ack.message());
  return CallResult::success({});
}

uint64_t Client::subscribe(const std::string& pattern, EventHandler handler,
                           uint64_t resume_after_seq) {
  return impl_->subscribe(pattern, std::move(handler), resume_after_seq);
}

void Client::unsubscribe(uint64_t subscription_id) { impl_->unsubscribe(subscription_id); }

void Client::register_service(const camus::RegisterRequest& registration, ReplyHandler handler) {
  impl_->register_service(registration, std::move(handler));
}

void Client::unregister_service(const std::string& name, ReplyHandler handler) {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    auto& registrations = impl_->registrations;
    registrations.erase(std::remove_if(registrations.begin(), registrations.end(),
                                       [&](const Impl::Registration& r) {
                                         return r.request.service().name() == name;
                                       }),
                        registrations.end());
  }
  camus::UnregisterRequest request;
  request.set_name(name);
  if (!handler) {
    handler = [name](CallResult result) {
      if (!result.ok()) {
        spdlog::warn("planet: unregistering service '{}' failed: {}: {}", name,
                     status_name(result.status), result.message);
      }
    };
  }
  impl_->call_async("camus.registry", "Unregister", request.SerializeAsString(),
                    std::chrono::milliseconds(0), std::move(handler), false, nullptr);
}

}  // namespace urs::planet
