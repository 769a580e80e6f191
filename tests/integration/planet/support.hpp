#pragma once
// Test support for the Planet integration tests: a bounded wait, raw TCP peers that speak (or
// break) the protocol byte by byte, and a small routing SessionHandler.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "camus.pb.h"
#include "process.hpp"
#include "raw_peer.hpp"
#include "urs/planet/client.hpp"
#include "urs/planet/codec.hpp"
#include "urs/planet/credentials.hpp"
#include "urs/planet/server.hpp"
#include "urs/util/secret.hpp"

namespace urs::planet::testing {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// urs::test::wait_until with this suite's default timeout.
inline bool eventually(const std::function<bool()>& condition, std::chrono::milliseconds timeout = 10s) {
  return urs::test::wait_until(condition, timeout);
}

// Options of a server on 127.0.0.1 (space "kr") and of a client that reconnects quickly.
inline ServerOptions server_options(uint16_t port = 0) {
  ServerOptions options;
  options.host = "127.0.0.1";
  options.port = port;
  options.space = "kr";
  return options;
}

// server_options() with a Ping every `interval` and a peer silent for `timeout` closed.
inline ServerOptions heartbeat_options(std::chrono::milliseconds interval, std::chrono::milliseconds timeout) {
  ServerOptions options = server_options();
  options.heartbeat_interval = interval;
  options.heartbeat_timeout = timeout;
  return options;
}

// Credentials of one token, named `name`, with `role`.
inline std::shared_ptr<const Authenticator> one_token(const std::string& token, Role role = OPERATOR,
                                                      const std::string& name = "space") {
  Credential credential;
  credential.name = name;
  credential.role = role;
  credential.token_sha256 = util::sha256_hex(token);
  return std::make_shared<const Credentials>(std::vector<Credential>{credential});
}

inline ClientOptions client_options(uint16_t port, const std::string& name) {
  ClientOptions options;
  options.port = port;
  options.peer_name = name;
  options.reconnect_min = 20ms;
  options.reconnect_max = 200ms;
  return options;
}

// A Server (server_options() unless given) serving `handler`, started on construction.
class StartedServer : public Server {
 public:
  explicit StartedServer(SessionHandler& handler, ServerOptions options = server_options())
      : Server(std::move(options), handler) {
    start();
  }
};

// Starts `client` and waits up to 5 s for its session; false if it has none by then.
inline bool start_and_connect(Client& client) {
  client.start();
  return client.wait_connected(5s);
}

inline long elapsed_ms(Clock::time_point since) {
  return static_cast<long>(std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - since).count());
}

using urs::test::RawPeer;

// Whether the next frame `raw` reads is of `kind` (Frame::kRefused or Frame::kGoodbye) with
// `status` and `reason`, after which the server closes the connection.
inline ::testing::AssertionResult closed_with(RawPeer& raw, Frame::BodyCase kind, Status status,
                                              const std::string& reason) {
  const auto frame = raw.read_frame();
  if (!frame || frame->body_case() != kind || (kind != Frame::kRefused && kind != Frame::kGoodbye)) {
    return ::testing::AssertionFailure() << "expected a frame of kind " << kind << ", got "
                                         << (frame ? frame->ShortDebugString() : "nothing");
  }
  const bool refused = kind == Frame::kRefused;
  const Status got_status = refused ? frame->refused().status() : frame->goodbye().status();
  const std::string& got_reason = refused ? frame->refused().reason() : frame->goodbye().reason();
  if (got_status != status || got_reason != reason) {
    return ::testing::AssertionFailure() << "got " << Status_Name(got_status) << " '" << got_reason << "'";
  }
  if (!raw.closed_by_server()) return ::testing::AssertionFailure() << "the server kept the connection open";
  return ::testing::AssertionSuccess();
}

// A listening socket on 127.0.0.1, port chosen by the kernel.
class RawListener {
 public:
  RawListener() : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t size = sizeof address;
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 || ::listen(fd_, 8) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&address), &size) != 0) {
      throw std::runtime_error("RawListener cannot listen");
    }
    port_ = ntohs(address.sin_port);
  }
  ~RawListener() { ::close(fd_); }
  uint16_t port() const { return port_; }
  // An accepted connection, or nullptr after `timeout`.
  std::unique_ptr<RawPeer> accept(std::chrono::milliseconds timeout) {
    pollfd poll_fd{fd_, POLLIN, 0};
    if (::poll(&poll_fd, 1, static_cast<int>(timeout.count())) <= 0) return nullptr;
    const int fd = ::accept(fd_, nullptr, nullptr);
    return fd < 0 ? nullptr : std::make_unique<RawPeer>(fd);
  }

 private:
  int fd_;
  uint16_t port_ = 0;
};

// Topic pattern: "*" matches one level, a trailing "#" any number of levels.
inline bool topic_matches(const std::string& pattern, const std::string& topic) {
  auto split = [](const std::string& text) {
    std::vector<std::string> parts;
    size_t start = 0;
    for (;;) {
      size_t slash = text.find('/', start);
      parts.push_back(text.substr(start, slash - start));
      if (slash == std::string::npos) return parts;
      start = slash + 1;
    }
  };
  const auto p = split(pattern);
  const auto t = split(topic);
  for (size_t i = 0; i < p.size(); ++i) {
    if (p[i] == "#") return true;
    if (i >= t.size() || (p[i] != "*" && p[i] != t[i])) return false;
  }
  return p.size() == t.size();
}

// A miniature CAMUS server for the tests: "echo" answers with the payload, "silent" never answers,
// camus.registry Register/Unregister route a service name to the registering session, requests
// to a registered name are forwarded to it, and a tiny event log sequences, dedupes (by
// the resumable session + publish_id), fans out and replays publishes. It outlives Server objects, like a
// persistent store would.
class TestHandler : public SessionHandler {
  mutable std::mutex mutex_;
  template <typename Fn>
  auto locked(Fn&& fn) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return fn();
  }

 public:
  struct Received {
    uint64_t session = 0;  // serial of the session, unique across Server objects
    std::string peer;
    Frame frame;
  };
  struct Silent {
    std::weak_ptr<Session> session;
    uint64_t call_id = 0;
  };

  // Knobs.
  std::atomic<bool> ack_publishes{true};    // false: sequence and store, but send no PublishAck
  std::atomic<bool> replay_overlap{false};  // also replay the event at resume_after_seq (a dup)

  // SessionHandler
  void on_open(const SessionPtr& session) override {
    std::lock_guard<std::mutex> lock(mutex_);
    sessions_[session->id()] = session;
    serials_[session.get()] = next_serial_++;
    opened_.push_back(session->hello());
    identities_.push_back(session->identity());
    changed_.notify_all();
  }

  void on_frame(const SessionPtr& session, Frame&& frame) override {
    std::lock_guard<std::mutex> lock(mutex_);
    received_.push_back({serials_[session.get()], session->hello().peer_name(), frame});
    switch (frame.body_case()) {
      case Frame::kRequest:
        handle_request(session, frame.request());
        break;
      case Frame::kReply:
        handle_provider_reply(frame.reply());
        break;
      case Frame::kPublish:
        handle_publish(session, frame.publish());
        break;
      case Frame::kSubscribe:
        handle_subscribe(session, frame.subscribe());
        break;
      case Frame::kUnsubscribe:
        subscriptions_.erase({session->id(), frame.unsubscribe().subscription_id()});
        break;
      default:
        break;
    }
    changed_.notify_all();
  }

  void on_close(const SessionPtr& session, const std::string& reason) override {
    std::lock_guard<std::mutex> lock(mutex_);
    closes_.push_back({session->id(), session->hello().peer_name(), reason});
    sessions_.erase(session->id());
    serials_.erase(session.get());
    for (auto it = subscriptions_.begin(); it != subscriptions_.end();) {
      it = it->first.first == session->id() ? subscriptions_.erase(it) : std::next(it);
    }
    for (auto it = providers_.begin(); it != providers_.end();) {
      it = it->second == session->id() ? providers_.erase(it) : std::next(it);
    }
    changed_.notify_all();
  }

  // Inspection (thread-safe copies).
  std::vector<Hello> opened() const {
    return locked([&] { return opened_; });
  }
  std::vector<Identity> identities() const {
    return locked([&] { return identities_; });
  }
  std::vector<Received> received() const {
    return locked([&] { return received_; });
  }
  std::vector<Received> received_from(const std::string& peer) const {
    return locked([&] {
      std::vector<Received> out;
      for (const auto& r : received_) {
        if (r.peer == peer) out.push_back(r);
      }
      return out;
    });
  }
  struct Close {
    uint64_t session;
    std::string peer;
    std::string reason;
  };
  std::vector<Close> closes() const {
    return locked([&] { return closes_; });
  }
  std::optional<std::string> close_reason_of(const std::string& peer) const {
    return locked([&]() -> std::optional<std::string> {
      for (const auto& c : closes_) {
        if (c.peer == peer) return c.reason;
      }
      return std::nullopt;
    });
  }
  size_t open_sessions() const {
    return locked([&] { return sessions_.size(); });
  }
  SessionPtr session_of(const std::string& peer) const {
    return locked([&]() -> SessionPtr {
      for (const auto& [id, s] : sessions_) {
        if (s->hello().peer_name() == peer) return s;
      }
      return nullptr;
    });
  }
  size_t subscriptions() const {
    return locked([&] { return subscriptions_.size(); });
  }
  std::vector<Silent> silent() const {
    return locked([&] { return silent_; });
  }
  int registrations_of(const std::string& name) const {
    return locked([&] {
      auto it = register_count_.find(name);
      return it == register_count_.end() ? 0 : it->second;
    });
  }
  bool provider_registered(const std::string& name) const {
    return locked([&] { return providers_.count(name) > 0; });
  }
  size_t stored_events() const {
    return locked([&] { return events_.size(); });
  }
  int duplicate_publishes() const {
    return locked([&] { return duplicates_; });
  }

 private:
  static Frame reply(uint64_t call_id, Status status, std::string payload, std::string message) {
    Frame frame;
    frame.mutable_reply()->set_call_id(call_id);
    frame.mutable_reply()->set_status(status);
    frame.mutable_reply()->set_payload(std::move(payload));
    frame.mutable_reply()->set_message(std::move(message));
    return frame;
  }

  void handle_request(const SessionPtr& session, const Request& request) {
    if (request.service() == "echo") {
      if (!request.oneway()) session->send(reply(request.call_id(), OK, request.payload(), ""));
      return;
    }
    if (request.service() == "silent") {
      silent_.push_back({session, request.call_id()});
      return;
    }
    if (request.service() == "camus.registry") {
      if (request.operation() == "Register") {
        camus::RegisterRequest registration;
        registration.ParseFromString(request.payload());
        providers_[registration.service().name()] = session->id();
        ++register_count_[registration.service().name()];
      } else if (request.operation() == "Unregister") {
        camus::UnregisterRequest unregistration;
        unregistration.ParseFromString(request.payload());
        providers_.erase(unregistration.name());
      }
      session->send(reply(request.call_id(), OK, "", ""));
      return;
    }
    auto provider = providers_.find(request.service());
    if (provider != providers_.end() && sessions_.count(provider->second)) {
      const uint64_t routed_id = next_routed_id_++;
      if (!request.oneway()) routes_[routed_id] = {session, request.call_id()};
      Frame forward;
      *forward.mutable_request() = request;
      forward.mutable_request()->set_call_id(routed_id);
      sessions_[provider->second]->send(std::move(forward));
      return;
    }
    if (!request.oneway()) {
      session->send(reply(request.call_id(), UNKNOWN_SERVICE, "", "no service '" + request.service() + "'"));
    }
  }

  void handle_provider_reply(const Reply& provider_reply) {
    auto route = routes_.find(provider_reply.call_id());
    if (route == routes_.end()) return;
    if (auto origin = route->second.session.lock()) {
      Frame frame;
      *frame.mutable_reply() = provider_reply;
      frame.mutable_reply()->set_call_id(route->second.call_id);
      origin->send(std::move(frame));
    }
    routes_.erase(route);
  }

  void handle_publish(const SessionPtr& session, const Publish& publish) {
    const auto key = std::make_pair(session->identity().session, publish.publish_id());
    auto seen = published_.find(key);
    uint64_t seq = 0;
    if (seen != published_.end()) {
      ++duplicates_;
      seq = seen->second;
    } else {
      Event event;
      event.set_seq(seq = ++last_seq_);
      event.set_topic(publish.topic());
      event.set_payload(publish.payload());
      event.set_content_type(publish.content_type());
      event.set_source(session->identity().name);
      events_.push_back(event);
      published_[key] = seq;
      for (const auto& [key2, subscription] : subscriptions_) {
        if (topic_matches(subscription.pattern, event.topic())) {
          send_event(subscription, event);
        }
      }
    }
    if (!ack_publishes) return;  // stored, but the publisher will have to resend
    Frame ack;
    ack.mutable_publish_ack()->set_publish_id(publish.publish_id());
    ack.mutable_publish_ack()->set_seq(seq);
    ack.mutable_publish_ack()->set_status(OK);
    session->send(std::move(ack));
  }

  struct Subscription {
    SessionPtr session;
    uint64_t id = 0;
    std::string pattern;
  };

  void send_event(const Subscription& subscription, Event event) {
    Frame frame;
    *frame.mutable_event() = std::move(event);
    frame.mutable_event()->set_subscription_id(subscription.id);
    subscription.session->send(std::move(frame));
  }

  void handle_subscribe(const SessionPtr& session, const Subscribe& subscribe) {
    Subscription subscription{session, subscribe.subscription_id(), subscribe.pattern()};
    subscriptions_[{session->id(), subscribe.subscription_id()}] = subscription;
    Frame ack;
    SubscribeAck& body = *ack.mutable_subscribe_ack();
    body.set_subscription_id(subscribe.subscription_id());
    body.set_status(OK);
    body.set_oldest_retained_seq(events_.empty() ? last_seq_ + 1 : events_.front().seq());
    body.set_last_seq(last_seq_);
    session->send(std::move(ack));
    const uint64_t resume = subscribe.resume_after_seq();
    if (resume == 0) return;
    for (const Event& event : events_) {
      const bool wanted = event.seq() > resume || (replay_overlap && event.seq() == resume);
      if (wanted && topic_matches(subscribe.pattern(), event.topic())) {
        send_event(subscription, event);
      }
    }
  }

  struct Route {
    std::weak_ptr<Session> session;
    uint64_t call_id = 0;
  };

  std::condition_variable changed_;
  std::map<uint64_t, SessionPtr> sessions_;  // by Session::id(), which restarts per Server
  std::map<const Session*, uint64_t> serials_;
  uint64_t next_serial_ = 1;
  std::vector<Hello> opened_;
  std::vector<Identity> identities_;
  std::vector<Received> received_;
  std::vector<Close> closes_;
  std::vector<Silent> silent_;
  std::map<std::string, uint64_t> providers_;  // service name -> session id
  std::map<std::string, int> register_count_;
  std::map<uint64_t, Route> routes_;
  uint64_t next_routed_id_ = 1;
  std::map<std::pair<uint64_t, uint64_t>, Subscription> subscriptions_;
  std::vector<Event> events_;
  std::map<std::pair<uint64_t, uint64_t>, uint64_t> published_;
  uint64_t last_seq_ = 0;
  int duplicates_ = 0;
};

}  // namespace urs::planet::testing
