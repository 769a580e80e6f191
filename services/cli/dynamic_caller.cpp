#include "dynamic_caller.hpp"

#include <google/protobuf/descriptor.pb.h>

#include "camus.pb.h"
#include "urs/util/json_text.hpp"

namespace urs::cli {

namespace gp = google::protobuf;
using planet::CallResult;

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

CallOutput DynamicCaller::call(const std::string& service, const std::string& operation, const std::string& json_args,
                               std::chrono::milliseconds deadline) {
  std::string interface_name;
  auto loaded = load_interface_of(service, interface_name);
  if (!loaded.ok()) return {loaded, {}};
  const gp::ServiceDescriptor* iface = pool_.find_service(interface_name);
  if (iface == nullptr) {
    return {
        CallResult::error(planet::INTERNAL, "the description of '" + service + "' does not define " + interface_name),
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
  const std::string repository = schema::repository_id(*iface);
  out = service + " implements " + interface_name + (repository.empty() ? "" : " (" + repository + ")") + "\n";
  for (int i = 0; i < iface->method_count(); ++i) {
    const auto* m = iface->method(i);
    const std::string signature = schema::idl_signature(*m);
    if (signature.empty()) continue;  // an attribute's _set_: its attribute line covers it
    out += "  " + signature + ";";
    // An attribute is called through its accessors.
    if (signature.find("attribute ") != std::string::npos) {
      const std::string name = m->name().substr(5);
      out += "  // " + m->name() + (iface->FindMethodByName("_set_" + name) ? ", _set_" + name : "");
    }
    out += "\n";
  }
  return CallResult::success({});
}

const gp::Descriptor* DynamicCaller::find_type(const std::string& full_name) {
  if (full_name.empty()) return nullptr;
  if (const auto* compiled = gp::DescriptorPool::generated_pool()->FindMessageTypeByName(full_name)) return compiled;
  if (const auto* loaded = pool_.find_message(full_name)) return loaded;
  const auto now = std::chrono::steady_clock::now();
  if (auto unknown = unknown_types_.find(full_name); unknown != unknown_types_.end() && now < unknown->second) {
    return nullptr;
  }
  camus::DescribeRequest request;
  request.set_type(full_name);
  auto result = client_.call("camus.registry", "Describe", request.SerializeAsString(), timeout_);
  camus::DescribeReply reply;
  if (result.ok() && reply.ParseFromString(result.payload) &&
      pool_.add_descriptor_set(reply.descriptor_set()).empty()) {
    if (const auto* described = pool_.find_message(full_name)) return described;
  }
  unknown_types_[full_name] = now + std::chrono::seconds(5);
  return nullptr;
}

std::unique_ptr<gp::Message> DynamicCaller::new_message(const gp::Descriptor& type) const {
  if (type.file()->pool() == gp::DescriptorPool::generated_pool()) {
    return std::unique_ptr<gp::Message>(gp::MessageFactory::generated_factory()->GetPrototype(&type)->New());
  }
  return pool_.new_message(type);
}

std::string DynamicCaller::event_payload_json(const std::string& content_type, const std::string& payload) {
  // A type neither compiled in nor described yet: ask the registry for it (Describe by type).
  if (content_type != "application/json") find_type(content_type);
  return schema::payload_to_json(&pool_, content_type, payload);
}

std::string DynamicCaller::event_json(const planet::Event& event) {
  return "{\"seq\":" + std::to_string(event.seq()) + ",\"topic\":" + util::json_string(event.topic()) +
         ",\"source\":" + util::json_string(event.source()) +
         ",\"time_unix_ns\":" + std::to_string(event.time_unix_ns()) +
         ",\"content_type\":" + util::json_string(event.content_type()) +
         ",\"payload\":" + event_payload_json(event.content_type(), event.payload()) + "}";
}

}  // namespace urs::cli
