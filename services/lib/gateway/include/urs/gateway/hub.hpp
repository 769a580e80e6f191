#pragma once
// Hub: the Foxglove WebSocket protocol's server side without sockets. It holds the channels and
// services the gateway offers, each connected client's subscriptions, and the connection graph;
// it answers what clients send and fans each published message out to the clients subscribed to
// its channel — only to them (docs/dashboard.md).
//
// With HubOptions.client_publish (a gateway playing a recording back) an operator's client may
// advertise channels of its own (clientPublish) and send messages on them: each goes to the
// PublishHandler, which says whether it was taken.
//
// Threading: every member function may be called from any thread; one mutex guards the state and
// is held while messages are handed to the clients' outboxes, which never block. Service calls are
// handed to their handler with the mutex released; the handler answers through `reply`, from any
// thread, exactly once. A published message is handed to the PublishHandler with the mutex
// released, on the thread that received it.
// Memory: what a slow client has not taken yet is bounded by its outbox (the WebSocket session
// drops it); what the hub keeps is bounded per channel (latched values, history) and by
// HubOptions.

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "urs/gateway/protocol.hpp"

namespace urs::gateway {

// Where one client's messages go: its WebSocket session. Never blocks; never calls the hub.
class Outbox {
 public:
  virtual ~Outbox() = default;
  // False once the client is being dropped (its queue overflowed or it left): nothing is sent.
  virtual bool send_text(std::string text) = 0;
  // A binary message: this client's `header` then `payload` (shared by every client it goes to).
  virtual bool send_binary(std::string header, std::shared_ptr<const std::string> payload) = 0;
};

// What a client may do, from what its login proved (docs/dashboard.md, "Security").
enum class Role { viewer, operator_ };
const char* role_name(Role role);

// Who is calling: handed to service handlers, which act with the caller's own credential.
struct Caller {
  uint64_t client = 0;
  Role role = Role::viewer;
  std::string login;     // the login session's id ("" for an anonymous viewer); see Logins. A secret.
  std::string identity;  // the login's credential name as the CAMUS server named it ("" if none)
};

// The outcome of one service call: `json` on success, else `error` (what the client is told).
struct CallReply {
  bool ok = false;
  std::string json;
  std::string error;
  static CallReply success(std::string json) { return {true, std::move(json), {}}; }
  static CallReply failure(std::string error) { return {false, {}, std::move(error)}; }
};
using ServiceHandler =
    std::function<void(const Caller& caller, std::string request_json, std::function<void(CallReply)> reply)>;
// Takes one message a client published on its channel `topic`; returns "" if taken, else why not
// (sent back to that client as an error Status).
using PublishHandler = std::function<std::string(const Caller& caller, const std::string& topic,
                                                 const std::string& schema_name, const std::string& payload)>;

// How a channel keeps what it published, for clients that subscribe later.
enum class Latch {
  none,     // a stream: a subscriber gets what is published after it subscribed
  keyed,    // the last message per key (a table: a subscriber gets every live key first)
  history,  // the last `history` messages (a log)
};

struct ChannelSpec {
  std::string topic;
  std::string schema_name;
  std::string schema;  // JSON Schema text
  Latch latch = Latch::none;
  std::size_t history = 0;
};

struct HubOptions {
  std::string name = "urs-gateway";
  std::vector<std::pair<std::string, std::string>> metadata;
  std::string session_id;                // serverInfo.sessionId: this process's run
  std::size_t max_calls_in_flight = 8;   // per client; more are refused at once
  std::size_t max_subscriptions = 4096;  // per client
  std::size_t max_keys_per_channel = 4096;
  bool client_publish = false;           // offer clientPublish (operators only)
  std::size_t max_client_channels = 64;  // per client
};

class Hub {
 public:
  explicit Hub(HubOptions options);
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;

  // ---- what the gateway offers ----
  // Advertised to every client at once; returns the channel id.
  uint32_t add_channel(ChannelSpec spec);
  void remove_channel(uint32_t id);
  // Sends `payload` (JSON) to the channel's subscribers, stamped `stamp_ns` (ns since the Unix
  // epoch); keeps it as the channel's latch says. `key`: for a keyed channel; `removed` drops
  // the key's latched value (the message is still sent, saying so).
  void publish(uint32_t channel, std::shared_ptr<const std::string> payload, uint64_t stamp_ns,
               const std::string& key = {}, bool removed = false);
  // Advertised to every client at once; returns the service id (service.id is ignored).
  uint32_t add_service(foxglove::Service service, ServiceHandler handler);
  void remove_service(uint32_t id);
  // The whole connection graph now; clients subscribed to it get what changed.
  void set_graph(const foxglove::GraphUpdate& graph);
  // Where clients' published messages go (with HubOptions.client_publish); set before clients come.
  void set_publish_handler(PublishHandler handler);

  // ---- clients ----
  // Sends serverInfo, the channels and the services; returns the client's id.
  uint64_t connect(std::shared_ptr<Outbox> outbox, Role role, std::string login, std::string identity = {});
  void disconnect(uint64_t client);
  // A client's text or binary message. Bad input is answered with a Status (error level) and
  // changes nothing; the client stays connected.
  void receive_text(uint64_t client, std::string_view text);
  void receive_binary(uint64_t client, std::string_view bytes);

  std::size_t clients() const;
  std::size_t subscribers(uint32_t channel) const;

 private:
  struct Latched {
    std::shared_ptr<const std::string> payload;
    uint64_t stamp_ns = 0;
  };
  struct ChannelState {
    foxglove::Channel channel;
    Latch latch = Latch::none;
    std::size_t history = 0;
    std::map<std::string, Latched> keyed;
    std::deque<Latched> recent;
    std::map<uint64_t, uint32_t> subscribers;  // client -> its subscription id
    bool full_reported = false;                // the keyed latch's limit was logged
  };
  struct ServiceState {
    foxglove::Service service;
    ServiceHandler handler;
  };
  struct Client {
    std::shared_ptr<Outbox> outbox;
    Role role = Role::viewer;
    std::string login;
    std::string identity;
    std::map<uint32_t, foxglove::ClientChannel> published;  // its clientPublish channels, by its ids
    std::map<uint32_t, uint32_t> subscriptions;             // subscription id -> channel id
    bool graph = false;
    std::size_t calls_in_flight = 0;
  };

  void status(Client& client, foxglove::StatusLevel level, const std::string& message);
  void subscribe(uint64_t id, Client& client, const foxglove::Subscribe& request);
  void unsubscribe(uint64_t id, Client& client, const foxglove::Unsubscribe& request);
  void call(uint64_t id, Client& client, foxglove::ServiceCallRequest request);
  void advertise(Client& client, const foxglove::ClientAdvertise& request);
  void unadvertise(Client& client, const foxglove::ClientUnadvertise& request);
  std::vector<std::string> capabilities() const;
  void answer(uint64_t client, uint32_t service_id, uint32_t call_id, const CallReply& reply);
  static void send_message(Client& client, uint32_t subscription, const Latched& message);

  const HubOptions options_;
  mutable std::mutex mutex_;
  uint32_t next_channel_ = 1;
  uint32_t next_service_ = 1;
  uint64_t next_client_ = 1;
  std::map<uint32_t, ChannelState> channels_;
  std::map<uint32_t, ServiceState> services_;
  std::map<uint64_t, Client> clients_;
  foxglove::GraphUpdate graph_;  // the whole graph, as last set
  PublishHandler publish_handler_;
};

}  // namespace urs::gateway
