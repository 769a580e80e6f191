#include "urs/gateway/protocol.hpp"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <cmath>
#include <cstring>
#include <tuple>

#include "urs/gateway/json_writer.hpp"

namespace urs::gateway::foxglove {

namespace gp = google::protobuf;

namespace {

uint32_t read_u32(std::string_view bytes, std::size_t at) {
  uint32_t value = 0;
  for (int i = 3; i >= 0; --i) value = (value << 8) | static_cast<uint8_t>(bytes[at + i]);
  return value;
}

void write_u32(std::string& out, uint32_t value) {
  for (int i = 0; i < 4; ++i) out += static_cast<char>((value >> (8 * i)) & 0xff);
}

void write_u64(std::string& out, uint64_t value) {
  for (int i = 0; i < 8; ++i) out += static_cast<char>((value >> (8 * i)) & 0xff);
}

// `value` if it is an integer in 0 .. 2^32-1.
std::optional<uint32_t> u32_value(const gp::Value& value) {
  if (value.kind_case() != gp::Value::kNumberValue) return std::nullopt;
  const double number = value.number_value();
  if (!(number >= 0 && number <= 4294967295.0) || std::floor(number) != number) return std::nullopt;
  return static_cast<uint32_t>(number);
}

// A field of `object` that must be an integer in 0 .. 2^32-1.
std::optional<uint32_t> u32_field(const gp::Struct& object, const std::string& name) {
  const auto it = object.fields().find(name);
  if (it == object.fields().end()) return std::nullopt;
  return u32_value(it->second);
}

// The array field `name` of an `op` message, at most kMaxIdsPerMessage `items` (the word for them
// in the error), each turned into an Item by `parse_item(value, where)`, which returns the Item or
// the ProtocolError for it (`where` names it: "<op>: <name>[<i>]"). The first refusal is returned.
template <typename Item, typename ParseItem>
std::variant<std::vector<Item>, ProtocolError> parse_list(const gp::Struct& message, const std::string& op,
                                                          const std::string& name, const std::string& items,
                                                          ParseItem parse_item) {
  const auto it = message.fields().find(name);
  if (it == message.fields().end() || it->second.kind_case() != gp::Value::kListValue) {
    return ProtocolError{op + ": '" + name + "' must be an array"};
  }
  const gp::ListValue& list = it->second.list_value();
  if (static_cast<std::size_t>(list.values_size()) > kMaxIdsPerMessage) {
    return ProtocolError{op + ": " + std::to_string(list.values_size()) + " " + items + " in one message (at most " +
                         std::to_string(kMaxIdsPerMessage) + ")"};
  }
  std::vector<Item> parsed;
  for (int i = 0; i < list.values_size(); ++i) {
    const std::string where = op + ": " + name + "[" + std::to_string(i) + "]";
    std::variant<Item, ProtocolError> item = parse_item(list.values(i), where);
    if (auto* error = std::get_if<ProtocolError>(&item)) return std::move(*error);
    parsed.push_back(std::get<Item>(std::move(item)));
  }
  return parsed;
}

ClientMessage parse_subscribe(const gp::Struct& message) {
  auto parsed = parse_list<Subscription>(
      message, "subscribe", "subscriptions", "subscriptions",
      [](const gp::Value& item, const std::string& where) -> std::variant<Subscription, ProtocolError> {
        if (item.kind_case() != gp::Value::kStructValue) return ProtocolError{where + " must be an object"};
        const auto id = u32_field(item.struct_value(), "id");
        const auto channel = u32_field(item.struct_value(), "channelId");
        if (!id) return ProtocolError{where + ".id must be an integer in 0..4294967295"};
        if (!channel) return ProtocolError{where + ".channelId must be an integer in 0..4294967295"};
        return Subscription{*id, *channel};
      });
  if (auto* error = std::get_if<ProtocolError>(&parsed)) return std::move(*error);
  return Subscribe{std::get<std::vector<Subscription>>(std::move(parsed))};
}

// The array `name` of ids of an `op` message, each an integer in 0..2^32-1.
std::variant<std::vector<uint32_t>, ProtocolError> parse_ids(const gp::Struct& message, const std::string& op,
                                                             const std::string& name) {
  return parse_list<uint32_t>(
      message, op, name, "ids",
      [](const gp::Value& item, const std::string& where) -> std::variant<uint32_t, ProtocolError> {
        const auto id = u32_value(item);
        if (!id) return ProtocolError{where + " must be an integer in 0..4294967295"};
        return *id;
      });
}

ClientMessage parse_unsubscribe(const gp::Struct& message) {
  auto parsed = parse_ids(message, "unsubscribe", "subscriptionIds");
  if (auto* error = std::get_if<ProtocolError>(&parsed)) return std::move(*error);
  return Unsubscribe{std::get<std::vector<uint32_t>>(std::move(parsed))};
}

// A string field of a client channel: present, at most `limit` bytes.
std::variant<std::string, ProtocolError> string_field(const gp::Struct& object, const std::string& name,
                                                      const std::string& where, std::size_t limit) {
  const auto it = object.fields().find(name);
  if (it == object.fields().end() || it->second.kind_case() != gp::Value::kStringValue) {
    return ProtocolError{where + "." + name + " must be a string"};
  }
  if (it->second.string_value().empty() || it->second.string_value().size() > limit) {
    return ProtocolError{where + "." + name + " must have 1.." + std::to_string(limit) + " bytes"};
  }
  return it->second.string_value();
}

ClientMessage parse_client_advertise(const gp::Struct& message) {
  auto parsed = parse_list<ClientChannel>(
      message, "advertise", "channels", "channels",
      [](const gp::Value& item, const std::string& where) -> std::variant<ClientChannel, ProtocolError> {
        if (item.kind_case() != gp::Value::kStructValue) return ProtocolError{where + " must be an object"};
        const gp::Struct& object = item.struct_value();
        const auto id = u32_field(object, "id");
        if (!id) return ProtocolError{where + ".id must be an integer in 0..4294967295"};
        ClientChannel channel;
        channel.id = *id;
        for (auto [name, limit, field] : {std::make_tuple("topic", kMaxNameLength, &channel.topic),
                                          std::make_tuple("encoding", kMaxEncodingLength, &channel.encoding),
                                          std::make_tuple("schemaName", kMaxNameLength, &channel.schema_name)}) {
          auto value = string_field(object, name, where, limit);
          if (auto* error = std::get_if<ProtocolError>(&value)) return std::move(*error);
          *field = std::get<std::string>(std::move(value));
        }
        return channel;
      });
  if (auto* error = std::get_if<ProtocolError>(&parsed)) return std::move(*error);
  return ClientAdvertise{std::get<std::vector<ClientChannel>>(std::move(parsed))};
}

ClientMessage parse_client_unadvertise(const gp::Struct& message) {
  auto parsed = parse_ids(message, "unadvertise", "channelIds");
  if (auto* error = std::get_if<ProtocolError>(&parsed)) return std::move(*error);
  return ClientUnadvertise{std::get<std::vector<uint32_t>>(std::move(parsed))};
}

}  // namespace

ClientMessage parse_text(std::string_view text) {
  if (text.size() > kMaxTextMessage) {
    return ProtocolError{"message of " + std::to_string(text.size()) + " bytes (at most " +
                         std::to_string(kMaxTextMessage) + ")"};
  }
  gp::Value root;
  const auto parsed = gp::util::JsonStringToMessage(gp::StringPiece(text.data(), text.size()), &root);
  if (!parsed.ok()) return ProtocolError{"not JSON: " + std::string(parsed.message())};
  if (root.kind_case() != gp::Value::kStructValue) return ProtocolError{"a message must be a JSON object"};
  const gp::Struct& message = root.struct_value();
  const auto op = message.fields().find("op");
  if (op == message.fields().end() || op->second.kind_case() != gp::Value::kStringValue) {
    return ProtocolError{"a message must have a string field 'op'"};
  }
  const std::string& name = op->second.string_value();
  if (name == "subscribe") return parse_subscribe(message);
  if (name == "unsubscribe") return parse_unsubscribe(message);
  if (name == "subscribeConnectionGraph") return SubscribeConnectionGraph{};
  if (name == "unsubscribeConnectionGraph") return UnsubscribeConnectionGraph{};
  if (name == "advertise") return parse_client_advertise(message);
  if (name == "unadvertise") return parse_client_unadvertise(message);
  for (const char* known :
       {"getParameters", "setParameters", "subscribeParameterUpdates", "unsubscribeParameterUpdates", "fetchAsset"}) {
    if (name == known) return Unsupported{name};
  }
  return ProtocolError{"unknown op '" + (name.size() > 64 ? name.substr(0, 64) + "..." : name) + "'"};
}

ClientMessage parse_binary(std::string_view bytes) {
  if (bytes.empty()) return ProtocolError{"empty binary message"};
  if (bytes.size() > kMaxBinaryMessage) {
    return ProtocolError{"binary message of " + std::to_string(bytes.size()) + " bytes (at most " +
                         std::to_string(kMaxBinaryMessage) + ")"};
  }
  const auto opcode = static_cast<uint8_t>(bytes[0]);
  if (opcode == kOpClientMessageData) {
    if (bytes.size() < 5) {
      return ProtocolError{"client message data: " + std::to_string(bytes.size()) + " bytes (at least 5)"};
    }
    return ClientMessageData{read_u32(bytes, 1), std::string(bytes.substr(5))};
  }
  if (opcode != kOpServiceCallRequest) {
    return ProtocolError{"unknown binary opcode " + std::to_string(opcode)};
  }
  if (bytes.size() < 13)
    return ProtocolError{"service call request: " + std::to_string(bytes.size()) + " bytes (at least 13)"};
  ServiceCallRequest call;
  call.service_id = read_u32(bytes, 1);
  call.call_id = read_u32(bytes, 5);
  const uint32_t encoding_length = read_u32(bytes, 9);
  if (encoding_length > kMaxEncodingLength || encoding_length > bytes.size() - 13) {
    return ProtocolError{"service call request: encoding length " + std::to_string(encoding_length) +
                         " exceeds the message or " + std::to_string(kMaxEncodingLength) + " bytes"};
  }
  call.encoding.assign(bytes.data() + 13, encoding_length);
  call.payload.assign(bytes.data() + 13 + encoding_length, bytes.size() - 13 - encoding_length);
  return call;
}

// ---- server -> client ------------------------------------------------------------------------

std::string server_info(const std::string& name, const std::vector<std::string>& capabilities,
                        const std::vector<std::string>& supported_encodings,
                        const std::vector<std::pair<std::string, std::string>>& metadata,
                        const std::string& session_id) {
  JsonWriter out;
  out.begin_object().key("op").value("serverInfo").key("name").value(name);
  out.key("capabilities").begin_array();
  for (const auto& capability : capabilities) out.value(capability);
  out.end_array();
  if (!supported_encodings.empty()) {
    out.key("supportedEncodings").begin_array();
    for (const auto& encoding : supported_encodings) out.value(encoding);
    out.end_array();
  }
  out.key("metadata").begin_object();
  for (const auto& [key, value] : metadata) out.key(key).value(value);
  out.end_object();
  out.key("sessionId").value(session_id);
  return out.end_object().take();
}

std::string status(StatusLevel level, const std::string& message, const std::string& id) {
  JsonWriter out;
  out.begin_object().key("op").value("status").key("level").value(static_cast<int>(level));
  out.key("message").value(message);
  if (!id.empty()) out.key("id").value(id);
  return out.end_object().take();
}

std::string advertise(const std::vector<const Channel*>& channels) {
  JsonWriter out;
  out.begin_object().key("op").value("advertise").key("channels").begin_array();
  for (const Channel* channel : channels) {
    out.begin_object();
    out.key("id").value(channel->id).key("topic").value(channel->topic).key("encoding").value(channel->encoding);
    out.key("schemaName").value(channel->schema_name).key("schema").value(channel->schema);
    out.key("schemaEncoding").value(channel->schema_encoding);
    out.end_object();
  }
  return out.end_array().end_object().take();
}

namespace {
std::string id_list(const char* op, const char* field, const std::vector<uint32_t>& ids) {
  JsonWriter out;
  out.begin_object().key("op").value(op).key(field).begin_array();
  for (uint32_t id : ids) out.value(id);
  return out.end_array().end_object().take();
}

void message_schema(JsonWriter& out, const MessageSchema& schema) {
  out.begin_object();
  out.key("encoding").value(schema.encoding).key("schemaName").value(schema.schema_name);
  out.key("schemaEncoding").value(schema.schema_encoding).key("schema").value(schema.schema);
  out.end_object();
}

void topic_nodes(JsonWriter& out, const char* field, const char* ids_field, const std::vector<TopicNodes>& list) {
  out.key(field).begin_array();
  for (const TopicNodes& nodes : list) {
    out.begin_object().key("name").value(nodes.name).key(ids_field).begin_array();
    for (const auto& id : nodes.ids) out.value(id);
    out.end_array().end_object();
  }
  out.end_array();
}
}  // namespace

std::string unadvertise(const std::vector<uint32_t>& channel_ids) {
  return id_list("unadvertise", "channelIds", channel_ids);
}

std::string advertise_services(const std::vector<const Service*>& services) {
  JsonWriter out;
  out.begin_object().key("op").value("advertiseServices").key("services").begin_array();
  for (const Service* service : services) {
    out.begin_object();
    out.key("id").value(service->id).key("name").value(service->name).key("type").value(service->type);
    out.key("request");
    message_schema(out, service->request);
    out.key("response");
    message_schema(out, service->response);
    // Not the deprecated requestSchema / responseSchema: clients that read `request` warn once per
    // service when they are present too.
    out.end_object();
  }
  return out.end_array().end_object().take();
}

std::string unadvertise_services(const std::vector<uint32_t>& service_ids) {
  return id_list("unadvertiseServices", "serviceIds", service_ids);
}

std::string service_call_failure(uint32_t service_id, uint32_t call_id, const std::string& message) {
  JsonWriter out;
  out.begin_object().key("op").value("serviceCallFailure").key("serviceId").value(service_id);
  out.key("callId").value(call_id).key("message").value(message);
  return out.end_object().take();
}

std::string connection_graph_update(const GraphUpdate& update) {
  JsonWriter out;
  out.begin_object().key("op").value("connectionGraphUpdate");
  topic_nodes(out, "publishedTopics", "publisherIds", update.published_topics);
  topic_nodes(out, "subscribedTopics", "subscriberIds", update.subscribed_topics);
  topic_nodes(out, "advertisedServices", "providerIds", update.advertised_services);
  out.key("removedTopics").begin_array();
  for (const auto& name : update.removed_topics) out.value(name);
  out.end_array().key("removedServices").begin_array();
  for (const auto& name : update.removed_services) out.value(name);
  return out.end_array().end_object().take();
}

std::string message_data_header(uint32_t subscription_id, uint64_t receive_time_ns) {
  std::string out;
  out.reserve(13);
  out += static_cast<char>(kOpMessageData);
  write_u32(out, subscription_id);
  write_u64(out, receive_time_ns);
  return out;
}

std::string service_call_response(uint32_t service_id, uint32_t call_id, const std::string& encoding,
                                  std::string_view payload) {
  std::string out;
  out.reserve(13 + encoding.size() + payload.size());
  out += static_cast<char>(kOpServiceCallResponse);
  write_u32(out, service_id);
  write_u32(out, call_id);
  write_u32(out, static_cast<uint32_t>(encoding.size()));
  out += encoding;
  out.append(payload.data(), payload.size());
  return out;
}

}  // namespace urs::gateway::foxglove
