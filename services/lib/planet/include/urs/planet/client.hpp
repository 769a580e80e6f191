#pragma once
// Planet client: one TCP session to a CAMUS server that survives disconnections.
//
// - Reconnects by itself with exponential backoff (reconnect_min .. reconnect_max).
// - After every handshake it first restores registrations (register_service) and subscriptions
//   (resuming after the last event seen), then flushes what was queued while disconnected.
// - Calls made while disconnected are queued (bounded by max_queued); a call that is already on
//   the wire when the connection drops fails with UNAVAILABLE "connection to server lost" and is
//   never retried (at-most-once). Publishes are kept until the server acknowledges them and are
//   resent after a reconnect (at-least-once; the server drops duplicates within its lifetime).
// - Heartbeats: the server's Welcome sets the interval and timeout; a silent server is declared
//   dead after heartbeat_timeout and the client reconnects.
// - Trace context: every call carries a W3C traceparent (Request.traceparent): the child of the
//   calling thread's current trace (util::TraceScope), else a new trace. A request served is
//   handled, and answered, inside a TraceScope of the traceparent it came with.
// - Identity: `token` names the client's credential to the server. The server's Welcome carries a
//   session secret that the client presents on every reconnect to resume its session (its
//   registrations and publish de-duplication carry over); the secret is never logged.
//
// Threading: callbacks (reply, event, request, connected) run on the I/O thread and must not block;
// call() blocks (not from a callback). unsubscribe() returns once its handler runs no more (waits).

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "camus.pb.h"
#include "planet.pb.h"
#include "urs/call/call.hpp"
#include "urs/call/recorder.hpp"
#include "urs/planet/status.hpp"
#include "urs/util/tls.hpp"
#include "urs/util/trace.hpp"

namespace urs::planet {

struct ClientOptions {
  std::string host = "127.0.0.1";
  uint16_t port = 0;
  std::string token;                 // the credential's token (e.g. read from --token-file)
  std::string peer_name = "client";  // for display only; the server acts on the credential
  Role role = CLIENT;                // the least role needed: SAM to register services
  std::chrono::milliseconds connect_timeout{2000};
  std::chrono::milliseconds reconnect_min{50};
  std::chrono::milliseconds reconnect_max{2000};
  // A call made without a deadline may wait this long for a connection (then UNAVAILABLE);
  // once sent, the server bounds it (see call_async).
  std::chrono::milliseconds queue_timeout{10000};
  size_t max_queued = 10000;  // calls + publishes waiting for a connection
  uint64_t max_message_bytes = 64ull << 20;
  uint32_t chunk_bytes = 64u << 10;
  // TLS 1.3 when tls.enabled: the server's certificate is verified against tls.ca_file (else the
  // system's CAs) and must name tls.server_name (else `host`); tls.cert_file/key_file present a
  // client certificate (mutual TLS).
  util::TlsConfig tls;
  // Metrics (docs/operations.md, "Monitoring"): the calls this client makes (`calls`, counted
  // under their names once the callee's answer confirms them: CallRecorder::record_unchecked) and
  // those it answers as a provider (`served_calls`, under the names of the services it registered).
  // Null: not counted. They outlive the client.
  call::CallRecorder* calls = nullptr;
  call::CallRecorder* served_calls = nullptr;
};

using ReplyHandler = std::function<void(CallResult)>;
using EventHandler = std::function<void(const Event&)>;

// Answers one incoming request (provider role): the neutral call::Responder, taking Planet's result
// type. Move-only; reply() may be called from any thread, once. Destroying it unanswered replies
// INTERNAL "provider dropped the request". A oneway request's responder answers nothing.
class Responder {
 public:
  Responder() = default;
  explicit Responder(call::Responder neutral) : neutral_(std::move(neutral)) {}
  void reply(CallResult result);
  bool pending() const { return neutral_.pending(); }

  // A responder that hands the result to `fn` (in-process hosts such as the server's service
  // container, and tests). Destroyed unanswered, it calls fn with INTERNAL as above.
  static Responder from_callback(std::function<void(CallResult)> fn);

  // The neutral responder it answers through (what agent hosts and links take).
  call::Responder neutral() && { return std::move(neutral_); }

 private:
  call::Responder neutral_;
};
using RequestHandler = std::function<void(const Request& request, Responder responder)>;

class Client {
 public:
  explicit Client(ClientOptions options);
  ~Client();  // stop()
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // Handlers are set before start().
  void set_request_handler(RequestHandler handler);  // provider role; default answers UNKNOWN_SERVICE
  void on_connected(std::function<void(const Welcome&)> handler);
  void on_disconnected(std::function<void(const std::string& reason)> handler);

  void start();  // starts the I/O thread and the first connection attempt; returns at once
  void stop();   // closes, fails everything pending with UNAVAILABLE "client stopped", joins

  bool connected() const;
  bool wait_connected(std::chrono::milliseconds timeout) const;
  // Why the last connection attempt or session failed (e.g. "refused: wrong token"); empty if none.
  std::string last_error() const;
  // Of the current (or last) session: identity() and role() say who the server takes this client
  // for. session_secret is cleared (the client keeps it to resume, and never logs it).
  Welcome welcome() const;

  // Request/reply. The handler runs exactly once. `deadline` > 0 bounds the whole call (queueing
  // included) and the rest of it is sent with the request. `deadline` 0 gives none: the request
  // carries deadline_ms 0, so the server applies the service's advertised deadline (else its
  // default) and answers DEADLINE_EXCEEDED itself when it passes; the client waits for that
  // answer (or a lost connection), and bounds only the wait for a connection by queue_timeout.
  void call_async(const std::string& service, const std::string& operation, std::string payload,
                  std::chrono::milliseconds deadline, ReplyHandler handler);
  // The same with an explicit trace: the request carries `trace` as it is (the caller made it,
  // e.g. `urs call`, which prints its id).
  void call_async(const std::string& service, const std::string& operation, std::string payload,
                  std::chrono::milliseconds deadline, ReplyHandler handler, const util::TraceContext& trace);
  CallResult call(const std::string& service, const std::string& operation, std::string payload,
                  std::chrono::milliseconds deadline = std::chrono::milliseconds{0});
  // Fire-and-forget; returns false (and logs) only if the queue is full.
  bool oneway(const std::string& service, const std::string& operation, std::string payload);

  // Events. publish() returns UNAVAILABLE with a message if the queue is full, OK otherwise.
  CallResult publish(const std::string& topic, std::string payload, const std::string& content_type);
  // Publishes and blocks until the server acknowledges the event: OK once it is sequenced and
  // stored, the server's refusal (e.g. BAD_ARGUMENTS for an invalid topic), or DEADLINE_EXCEEDED
  // after `timeout` (the event stays queued and may still be delivered). Not from a callback.
  CallResult publish_and_wait(const std::string& topic, std::string payload, const std::string& content_type,
                              std::chrono::milliseconds timeout);
  uint64_t subscribe(const std::string& pattern, EventHandler handler, uint64_t resume_after_seq = 0);
  void unsubscribe(uint64_t subscription_id);

  // Provider role: registrations are kept and re-sent after every reconnect.
  // The handler gets the result of the first registration attempt.
  void register_service(const camus::RegisterRequest& registration, ReplyHandler handler = {});
  void unregister_service(const std::string& name, ReplyHandler handler = {});

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

}  // namespace urs::planet
