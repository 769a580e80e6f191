#include "dynamic_caller.hpp"

#include <google/protobuf/descriptor.pb.h>

#include <cstdio>

#include "camus.pb.h"

namespace urs::cli {

namespace gp = google::protobuf;
using planet::CallResult;

namespace {

std::string base64(const std::string& data) {
  static const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((data.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < data.size(); i += 3) {
    uint32_t n = (uint8_t(data[i]) << 16) | (uint8_t(data[i + 1]) << 8) | uint8_t(data[i + 2]);
    for (int s = 18; s >= 0; s -= 6) out += alphabet[(n >> s) & 63];
  }
  if (i < data.size()) {
    uint32_t n = uint8_t(data[i]) << 16;
    if (i + 1 < data.size()) n |= uint8_t(data[i + 1]) << 8;
    out += alphabet[(n >> 18) & 63];
    out += alphabet[(n >> 12) & 63];
    out += i + 1 < data.size() ? alphabet[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// A JSON string literal (RFC 8259 escaping).
std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (unsigned char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20) {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\u%04x", c);
      out += escaped;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

}  // namespace

CallResult DynamicCaller::load_interface_of(const std::string& service, std::string& interface_name) {
  auto known = interface_of_.find(service);
  if (known != interface_of_.end()) {
    interface_name = known->second;
    return CallResult::success({});
  }
  camus::DescribeRequest request;
  request.set_service(service);
  auto result = client_.call("camus.registry", "Describe", request.SerializeAsString(), timeout_);
  if (!result.ok()) return result;
  camus::DescribeReply reply;
  if (!reply.ParseFromString(result.payload)) {
    return CallResult::error(planet::INTERNAL, "camus.registry.Describe returned an unreadable reply");
  }
  auto error = pool_.add_descriptor_set(reply.descriptor_set());
  if (!error.empty()) {
    return CallResult::error(planet::INTERNAL, "interface of '" + service + "' cannot be loaded: " + error);
  }
  interface_of_[service] = reply.interface();
  interface_name = reply.interface();
  return CallResult::success({});
}

CallOutput DynamicCaller::call(const std::string& service, const std::string& operation,
                               const std::string& json_args, std::chrono::milliseconds deadline) {
  std::string interface_name;
  auto loaded = load_interface_of(service, interface_name);
  if (!loaded.ok()) return {loaded, {}};
  const gp::ServiceDescriptor* iface = pool_.find_service(interface_name);
  if (iface == nullptr) {
    return {CallResult::error(planet::INTERNAL, "the description of '" + service + "' does not define " +
                                                    interface_name),
            {}};
  }
  const gp::MethodDescriptor* method = iface->FindMethodByName(operation);
  if (method == nullptr) {
    std::string known;
    for (int i = 0; i < iface->method_count(); ++i) known += (i ? ", " : "") + iface->method(i)->name();
    return {CallResult::error(planet::UNKNOWN_OPERATION, "interface " + interface_name + " has no operation '" +
                                                             operation + "' (operations: " + known + ")"),
            {}};
  }
  auto request = pool_.new_message(*method->input_type());
  auto error = schema::json_to_message(json_args.empty() ? "{}" : json_args, *request);
  if (!error.empty()) {
    return {CallResult::error(planet::BAD_ARGUMENTS, "arguments of " + service + "." + operation + ": " + error), {}};
  }
  CallOutput output;
  if (schema::is_oneway(*method)) {
    if (!client_.oneway(service, operation, request->SerializeAsString())) {
      output.result = CallResult::error(planet::UNAVAILABLE, "outgoing queue is full");
    }
    return output;
  }
  output.result = client_.call(service, operation, request->SerializeAsString(), deadline);
  if (output.result.ok()) {
    auto reply = pool_.new_message(*method->output_type());
    if (!reply->ParseFromString(output.result.payload)) {
      output.result = CallResult::error(planet::INTERNAL, "reply is not a valid " + method->output_type()->full_name());
      return output;
    }
    schema::message_to_json(*reply, output.json);
  } else if (output.result.status == planet::USER_EXCEPTION) {
    output.json = event_payload_json(output.result.exception_type, output.result.payload);
  }
  return output;
}

CallResult DynamicCaller::describe(const std::string& service, std::string& out) {
  std::string interface_name;
  auto loaded = load_interface_of(service, interface_name);
  if (!loaded.ok()) return loaded;
  const gp::ServiceDescriptor* iface = pool_.find_service(interface_name);
  if (iface == nullptr) return CallResult::error(planet::INTERNAL, "no description of " + interface_name);
  out = service + " implements " + interface_name + "\n";
  for (int i = 0; i < iface->method_count(); ++i) {
    const auto* m = iface->method(i);
    out += "  " + m->name() + "(" + m->input_type()->full_name() + ") -> " + m->output_type()->full_name();
    if (schema::is_oneway(*m)) out += "  [oneway]";
    auto raised = schema::raises(*m);
    if (!raised.empty()) {
      out += "  raises";
      for (const auto& r : raised) out += " " + r;
    }
    out += "\n";
  }
  return CallResult::success({});
}

void DynamicCaller::load_all_interfaces() {
  if (loaded_all_) return;
  loaded_all_ = true;
  auto result = client_.call("camus.registry", "List", camus::ListRequest().SerializeAsString(), timeout_);
  camus::ListReply list;
  if (!result.ok() || !list.ParseFromString(result.payload)) return;
  for (const auto& service : list.services()) {
    std::string ignored;
    load_interface_of(service.name(), ignored);
  }
}

std::string DynamicCaller::event_payload_json(const std::string& content_type, const std::string& payload) {
  if (content_type == "application/json") return payload.empty() ? "null" : payload;
  auto decode = [&](const gp::Descriptor* type, const gp::Message* prototype) -> std::string {
    std::unique_ptr<gp::Message> message(prototype != nullptr ? prototype->New() : pool_.new_message(*type).release());
    std::string json;
    if (message->ParseFromString(payload) && schema::message_to_json(*message, json).empty()) return json;
    return {};
  };
  if (!content_type.empty()) {
    if (const auto* compiled = gp::DescriptorPool::generated_pool()->FindMessageTypeByName(content_type)) {
      auto json = decode(compiled, gp::MessageFactory::generated_factory()->GetPrototype(compiled));
      if (!json.empty()) return json;
    }
    const auto* described = pool_.find_message(content_type);
    if (described == nullptr) {
      load_all_interfaces();
      described = pool_.find_message(content_type);
    }
    if (described != nullptr) {
      auto json = decode(described, nullptr);
      if (!json.empty()) return json;
    }
  }
  return "{\"base64\":" + quoted(base64(payload)) + "}";
}

std::string DynamicCaller::event_json(const planet::Event& event) {
  return "{\"seq\":" + std::to_string(event.seq()) + ",\"topic\":" + quoted(event.topic()) +
         ",\"source\":" + quoted(event.source()) + ",\"time_unix_ns\":" + std::to_string(event.time_unix_ns()) +
         ",\"content_type\":" + quoted(event.content_type()) +
         ",\"payload\":" + event_payload_json(event.content_type(), event.payload()) + "}";
}

}  // namespace urs::cli
