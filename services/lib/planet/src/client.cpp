// The Planet client: a façade over its components (src/client/), each with its own state and lock:
//
//   Connection     connect, handshake, heartbeats, reconnect with backoff (the SessionListener
//                  below is told when a session opens, what it carries, and when it closes)
//   PendingCalls   calls queued and in flight, their deadlines (at most once)
//   PublishQueue   publishes until acknowledged (at least once)
//   Subscriptions  subscriptions, their handlers, resuming after the last event
//   Registrations  provided services, registered again on every session
//   serve_request  requests routed to this client, answered through a Responder
//   IoThread       the thread everything above runs on
//   QueueBudget    max_queued, shared by queued calls and unacknowledged publishes
//
// Lock order: Connection → Registrations → PendingCalls; every other lock is a leaf. User
// callbacks never run under a lock.

#include "urs/planet/client.hpp"

#include <spdlog/spdlog.h>

#include <future>
#include <stdexcept>
#include <vector>

#include "client/connection.hpp"
#include "client/deferred.hpp"
#include "client/io_thread.hpp"
#include "client/pending_calls.hpp"
#include "client/publish_queue.hpp"
#include "client/queue_budget.hpp"
#include "client/registrations.hpp"
#include "client/request_serving.hpp"
#include "client/subscriptions.hpp"
#include "urs/planet/call_adapter.hpp"
#include "urs/planet/codec.hpp"

namespace urs::planet {

using std::chrono::milliseconds;

namespace {

ClientOptions validated(ClientOptions options) {
  std::vector<std::string> errors;
  auto ms = [](milliseconds value) { return std::to_string(value.count()) + " ms"; };
  if (options.connect_timeout.count() <= 0) {
    errors.push_back("connect_timeout " + ms(options.connect_timeout) + " must be > 0");
  }
  if (options.reconnect_min.count() <= 0 || options.reconnect_max < options.reconnect_min) {
    errors.push_back("reconnect_min " + ms(options.reconnect_min) + " and reconnect_max " + ms(options.reconnect_max) +
                     " must satisfy 0 < min <= max");
  }
  if (options.queue_timeout.count() <= 0) {
    errors.push_back("queue_timeout " + ms(options.queue_timeout) + " must be > 0");
  }
  check_message_limits(options.chunk_bytes, options.max_message_bytes, errors);
  if (errors.empty()) return options;
  std::string message = "invalid Planet ClientOptions:";
  for (const auto& error : errors) message += "\n  " + error;
  throw std::invalid_argument(message);
}

std::string target_of(const ClientOptions& options) { return options.host + ":" + std::to_string(options.port); }

constexpr const char* kStopped = "client stopped";

}  // namespace

struct Client::Impl final : detail::SessionListener {
  explicit Impl(ClientOptions options_in)
      : options(validated(std::move(options_in))),
        budget(options.max_queued, target_of(options)),
        calls(*io, target_of(options), options.queue_timeout, budget),
        registrations(calls),
        publishes(budget),
        subscriptions(target_of(options)),
        connection(options, io, *this),
        thread(io) {
    request_handler = [](const Request& request, Responder responder) {
      responder.reply(CallResult::error(Status::UNKNOWN_SERVICE,
                                        "no request handler on this client for service '" + request.service() + "'"));
    };
  }

  // Runs `out` on the I/O thread when called from another thread of a running client, else here.
  void finish(detail::Deferred& out) {
    thread.post_or_keep(out);
    detail::run_all(out);
  }

  void call_async(const std::string& service, const std::string& operation, std::string payload, milliseconds deadline,
                  ReplyHandler handler, bool oneway, bool* accepted,
                  const util::TraceContext& trace = util::outgoing_trace()) {
    Request request;
    request.set_service(service);
    request.set_operation(operation);
    request.set_payload(std::move(payload));
    request.set_oneway(oneway);
    request.set_traceparent(trace.traceparent());
    if (options.calls != nullptr && handler) handler = recorded(service, operation, std::move(handler));
    detail::Deferred out;
    const bool ok = calls.start(std::move(request), deadline, std::move(handler), out);
    if (accepted) *accepted = ok;
    finish(out);
  }

  // `handler`, which also counts the call in options.calls when it ends.
  ReplyHandler recorded(const std::string& service, const std::string& operation, ReplyHandler handler) {
    return [recorder = options.calls, service, operation, handler = std::move(handler),
            start = std::chrono::steady_clock::now()](CallResult result) {
      recorder->record_unchecked(service, operation, to_call(result.status), std::chrono::steady_clock::now() - start);
      handler(std::move(result));
    };
  }

  // I/O thread (or a client never started): fails what waits, closes the connection.
  void shutdown() {
    detail::Deferred out;
    calls.close(kStopped, out);
    registrations.close(kStopped, out);
    publishes.close();
    subscriptions.detach();
    connection.shutdown();
    detail::run_all(out);
  }

  // detail::SessionListener
  void session_opened(const std::shared_ptr<detail::FrameSink>& sink, const Welcome& welcome, uint64_t send_limit,
                      detail::Deferred& out) override {
    // In this order: registrations, subscriptions, unacknowledged publishes, queued calls.
    calls.open(sink, send_limit);
    registrations.open(out);
    subscriptions.open(sink);
    publishes.open(sink, send_limit);
    calls.flush(out);
    if (connected_handler) out.push_back([handler = connected_handler, welcome] { handler(welcome); });
  }

  void session_frame(const std::shared_ptr<detail::FrameSink>& sink, Frame&& frame) override {
    detail::Deferred out;
    switch (frame.body_case()) {
      case Frame::kReply:
        calls.on_reply(std::move(*frame.mutable_reply()), out);
        break;
      case Frame::kEvent:
        subscriptions.on_event(frame.event());
        break;
      case Frame::kRequest:
        detail::serve_request(request_handler, frame.request(), sink, options.served_calls,
                              options.served_calls != nullptr && registrations.has(frame.request().service()));
        break;
      case Frame::kPublishAck:
        publishes.on_ack(frame.publish_ack());
        break;
      case Frame::kSubscribeAck:
        subscriptions.on_ack(frame.subscribe_ack());
        break;
      default:
        spdlog::debug("planet: ignoring unexpected {} frame from {}", frame_body_name(frame), connection.target());
        break;
    }
    detail::run_all(out);
  }

  void session_closed(const std::string& reason, bool was_open, detail::Deferred& out) override {
    calls.detach(out);
    registrations.detach();
    subscriptions.detach();
    publishes.detach();
    if (was_open && disconnected_handler) out.push_back([handler = disconnected_handler, reason] { handler(reason); });
  }

  const ClientOptions options;
  // Declared first, destroyed last: the Links and timers of the components need it.
  const std::shared_ptr<asio::io_context> io = std::make_shared<asio::io_context>();
  detail::QueueBudget budget;
  detail::PendingCalls calls;
  detail::Registrations registrations;
  detail::PublishQueue publishes;
  detail::Subscriptions subscriptions;
  detail::Connection connection;
  detail::IoThread thread;

  // Set before start(), read-only afterwards.
  RequestHandler request_handler;
  std::function<void(const Welcome&)> connected_handler;
  std::function<void(const std::string&)> disconnected_handler;
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

void Client::start() {
  impl_->thread.start([impl = impl_.get()] { impl->connection.start(); });
}

void Client::stop() {
  impl_->thread.stop([impl = impl_.get()] { impl->shutdown(); });
}

bool Client::connected() const { return impl_->connection.connected(); }

bool Client::wait_connected(std::chrono::milliseconds timeout) const {
  return impl_->connection.wait_connected(timeout);
}

std::string Client::last_error() const { return impl_->connection.last_error(); }

Welcome Client::welcome() const { return impl_->connection.welcome(); }

void Client::call_async(const std::string& service, const std::string& operation, std::string payload,
                        std::chrono::milliseconds deadline, ReplyHandler handler, const util::TraceContext& trace) {
  impl_->call_async(service, operation, std::move(payload), deadline, std::move(handler), false, nullptr, trace);
}

void Client::call_async(const std::string& service, const std::string& operation, std::string payload,
                        std::chrono::milliseconds deadline, ReplyHandler handler) {
  impl_->call_async(service, operation, std::move(payload), deadline, std::move(handler), false, nullptr);
}

CallResult Client::call(const std::string& service, const std::string& operation, std::string payload,
                        std::chrono::milliseconds deadline) {
  if (impl_->thread.started() && impl_->thread.here()) {
    return CallResult::error(Status::INTERNAL,
                             "Client::call() would block the client's I/O thread; use call_async() from callbacks");
  }
  if (!impl_->thread.started() && !impl_->thread.stopping()) {
    return CallResult::error(Status::UNAVAILABLE, "client not started: call start() first");
  }
  auto promise = std::make_shared<std::promise<CallResult>>();
  auto future = promise->get_future();
  impl_->call_async(
      service, operation, std::move(payload), deadline,
      [promise](CallResult result) { promise->set_value(std::move(result)); }, false, nullptr);
  return future.get();
}

bool Client::oneway(const std::string& service, const std::string& operation, std::string payload) {
  bool accepted = false;
  impl_->call_async(service, operation, std::move(payload), milliseconds(0), {}, true, &accepted);
  return accepted;
}

CallResult Client::publish(const std::string& topic, std::string payload, const std::string& content_type) {
  return impl_->publishes.publish(topic, std::move(payload), content_type);
}

CallResult Client::publish_and_wait(const std::string& topic, std::string payload, const std::string& content_type,
                                    std::chrono::milliseconds timeout) {
  return impl_->publishes.publish_and_wait(topic, std::move(payload), content_type, timeout);
}

uint64_t Client::subscribe(const std::string& pattern, EventHandler handler, uint64_t resume_after_seq) {
  return impl_->subscriptions.subscribe(pattern, std::move(handler), resume_after_seq);
}

void Client::unsubscribe(uint64_t subscription_id) { impl_->subscriptions.unsubscribe(subscription_id); }

void Client::register_service(const camus::RegisterRequest& registration, ReplyHandler handler) {
  detail::Deferred out;
  impl_->registrations.add(registration, std::move(handler), out);
  impl_->finish(out);
}

void Client::unregister_service(const std::string& name, ReplyHandler handler) {
  impl_->registrations.remove(name);
  camus::UnregisterRequest request;
  request.set_name(name);
  if (!handler) {
    handler = [name](CallResult result) {
      if (!result.ok()) {
        spdlog::warn("planet: unregistering service '{}' failed: {}: {}", name, status_name(result.status),
                     result.message);
      }
    };
  }
  impl_->call_async("camus.registry", "Unregister", request.SerializeAsString(), milliseconds(0), std::move(handler),
                    false, nullptr);
}

}  // namespace urs::planet
