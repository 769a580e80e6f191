#pragma once
// The Foxglove WebSocket protocol, subprotocol "foxglove.websocket.v1" (public specification:
// foxglove/ws-protocol, docs/spec.md), as far as urs-gateway speaks it: the client's requests
// parsed from WebSocket messages, and the server's messages encoded. No sockets here: text frames
// in, bytes out (docs/dashboard.md lists what the gateway supports).
//
// Every input is hostile: parse_text() and parse_binary() never throw, check sizes and counts
// before they allocate, and say precisely what is wrong (ProtocolError::message), so the server
// can answer with a Status message and keep the connection.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace urs::gateway::foxglove {

inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";

// Limits on what one client message may hold (checked before anything is allocated for it).
inline constexpr std::size_t kMaxTextMessage = 64 * 1024;      // bytes of one JSON message
inline constexpr std::size_t kMaxBinaryMessage = 1024 * 1024;  // bytes of one binary message
inline constexpr std::size_t kMaxIdsPerMessage = 1024;         // subscriptions, ids per message
inline constexpr std::size_t kMaxEncodingLength = 64;          // bytes of a service call's encoding
inline constexpr std::size_t kMaxNameLength = 256;             // bytes of a client channel's topic or schema name

// ---- client -> server ------------------------------------------------------------------------

struct Subscription {
  uint32_t id = 0;  // chosen by the client
  uint32_t channel_id = 0;
};
struct Subscribe {
  std::vector<Subscription> subscriptions;
};
struct Unsubscribe {
  std::vector<uint32_t> subscription_ids;
};
struct SubscribeConnectionGraph {};
struct UnsubscribeConnectionGraph {};
struct ServiceCallRequest {
  uint32_t service_id = 0;
  uint32_t call_id = 0;
  std::string encoding;
  std::string payload;
};
// clientPublish: a client's channels (their schema, if sent, is not kept), their withdrawal, and
// one message on one of them.
struct ClientChannel {
  uint32_t id = 0;  // chosen by the client
  std::string topic;
  std::string encoding;
  std::string schema_name;
};
struct ClientAdvertise {
  std::vector<ClientChannel> channels;
};
struct ClientUnadvertise {
  std::vector<uint32_t> channel_ids;
};
struct ClientMessageData {
  uint32_t channel_id = 0;
  std::string payload;
};
// An operation of the specification the gateway does not offer (parameters, assets): refused
// with a Status naming it.
struct Unsupported {
  std::string op;
};

struct ProtocolError {
  std::string message;  // e.g. "subscribe: subscriptions[2].channelId is not an integer in 0..4294967295"
};

using ClientMessage =
    std::variant<Subscribe, Unsubscribe, SubscribeConnectionGraph, UnsubscribeConnectionGraph, ServiceCallRequest,
                 ClientAdvertise, ClientUnadvertise, ClientMessageData, Unsupported, ProtocolError>;

ClientMessage parse_text(std::string_view text);
ClientMessage parse_binary(std::string_view bytes);

// ---- server -> client ------------------------------------------------------------------------

enum class StatusLevel { info = 0, warning = 1, error = 2 };

struct Channel {
  uint32_t id = 0;
  std::string topic;
  std::string encoding = "json";
  std::string schema_name;
  std::string schema;  // JSON Schema text for encoding "json"
  std::string schema_encoding = "jsonschema";
};

struct MessageSchema {
  std::string encoding = "json";
  std::string schema_name;
  std::string schema;
  std::string schema_encoding = "jsonschema";
};

struct Service {
  uint32_t id = 0;
  std::string name;
  std::string type;
  MessageSchema request;
  MessageSchema response;
};

struct TopicNodes {
  std::string name;
  std::vector<std::string> ids;  // publisher, subscriber or provider ids
};

struct GraphUpdate {
  std::vector<TopicNodes> published_topics;
  std::vector<TopicNodes> subscribed_topics;
  std::vector<TopicNodes> advertised_services;
  std::vector<std::string> removed_topics;
  std::vector<std::string> removed_services;
  bool empty() const {
    return published_topics.empty() && subscribed_topics.empty() && advertised_services.empty() &&
           removed_topics.empty() && removed_services.empty();
  }
};

// JSON messages (text frames).
std::string server_info(const std::string& name, const std::vector<std::string>& capabilities,
                        const std::vector<std::string>& supported_encodings,
                        const std::vector<std::pair<std::string, std::string>>& metadata,
                        const std::string& session_id);
std::string status(StatusLevel level, const std::string& message, const std::string& id = {});
std::string advertise(const std::vector<const Channel*>& channels);
std::string unadvertise(const std::vector<uint32_t>& channel_ids);
std::string advertise_services(const std::vector<const Service*>& services);
std::string unadvertise_services(const std::vector<uint32_t>& service_ids);
std::string service_call_failure(uint32_t service_id, uint32_t call_id, const std::string& message);
std::string connection_graph_update(const GraphUpdate& update);

// Binary messages. message_data_header() is the 13 bytes before the payload, so one payload can be
// sent to many clients without copying it.
std::string message_data_header(uint32_t subscription_id, uint64_t receive_time_ns);
std::string service_call_response(uint32_t service_id, uint32_t call_id, const std::string& encoding,
                                  std::string_view payload);

inline constexpr uint8_t kOpMessageData = 0x01;
inline constexpr uint8_t kOpServiceCallResponse = 0x03;
inline constexpr uint8_t kOpClientMessageData = 0x01;
inline constexpr uint8_t kOpServiceCallRequest = 0x02;

}  // namespace urs::gateway::foxglove
