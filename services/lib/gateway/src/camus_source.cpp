#include "urs/gateway/camus_source.hpp"

#include <spdlog/spdlog.h>

#include "camus.pb.h"
#include "urs/schema/json.hpp"

namespace urs::gateway {

namespace gp = google::protobuf;

namespace {
constexpr const char* kSource = "camus";
constexpr const char* kServerPeer = "camus-server";  // the owner of the server's built-in services

std::string property(const camus::ServiceInfo& info, const std::string& key) {
  auto it = info.properties().find(key);
  return it == info.properties().end() ? std::string() : it->second;
}

ContextEntry entry_of(const std::string& space, const camus::ContextEntry& entry) {
  ContextEntry out;
  out.set_space(space);
  out.set_key(entry.key());
  *out.mutable_value() = entry.value();
  out.set_source(entry.source());
  out.set_version(static_cast<double>(entry.version()));
  out.set_stamp(static_cast<double>(entry.updated_unix_ns()) / 1e9);
  return out;
}
}  // namespace

CamusSource::CamusSource(CamusSourceOptions options, Logins& logins) : options_(std::move(options)), logins_(logins) {}

CamusSource::~CamusSource() { stop(); }

void CamusSource::start(ViewSink& sink) {
  sink_ = &sink;
  client_ = std::make_unique<planet::Client>(options_.client);
  client_->on_connected([this](const planet::Welcome&) {
    context_due_ = true;
    poller_.wake();
  });
  client_->on_disconnected([this](const std::string& why) {
    spdlog::warn("gateway: CAMUS server of {} lost: {}", options_.space, why);
    poller_.wake();
  });
  client_->subscribe("#", [this](const planet::Event& event) { on_event(event); });
  client_->start();
  poller_.start(options_.refresh, [this] {
    refresh();
    if (client_->connected() && context_due_.exchange(false)) read_context();
  });
}

void CamusSource::stop() {
  poller_.stop();
  if (client_) client_->stop();
}

void CamusSource::refresh() {
  std::vector<Service> services;
  std::vector<Component> components;
  std::vector<Operation> operations;
  if (client_->connected()) {
    const auto listed =
        client_->call("camus.registry", "List", camus::ListRequest().SerializeAsString(), options_.read_timeout);
    camus::ListReply list;
    if (!listed.ok() || !list.ParseFromString(listed.payload)) {
      spdlog::warn("gateway: reading the registry of {} failed: {}: {}", options_.space,
                   planet::status_name(listed.status), listed.message);
      return;  // what was reported stays until a read succeeds
    }
    for (const camus::ServiceInfo& info : list.services()) {
      if (!described_.count(info.interface())) {
        camus::DescribeRequest request;
        request.set_interface(info.interface());
        const auto described =
            client_->call("camus.registry", "Describe", request.SerializeAsString(), options_.read_timeout);
        camus::DescribeReply reply;
        if (described.ok() && reply.ParseFromString(described.payload)) {
          const std::string error = decoder_.pool().add_descriptor_set(reply.descriptor_set());
          if (error.empty()) {
            described_.insert(info.interface());
          } else {
            spdlog::warn("gateway: the description of {} cannot be used: {}", info.interface(), error);
          }
        }
      }
      const std::string origin = property(info, "urslink.origin");
      Service service;
      service.set_space(options_.space);
      service.set_name(info.name());
      service.set_interface(info.interface());
      service.set_origin(origin.empty() ? "camus" : origin);
      service.set_provider(info.owner());
      service.set_bridge(property(info, "urslink.bridge"));
      // As `urs ls` shows it: the provider's health where it reports one it cannot serve with.
      const std::string health = property(info, "urslink.health");
      service.set_state(health.empty() || health == "ok" ? info.state() : health);
      service.set_seen_via("camus");
      services.push_back(service);
      if (info.owner() != kServerPeer) {
        Component agent;
        agent.set_space(options_.space);
        agent.set_name(info.name());
        agent.set_kind("agent");
        agent.set_state(info.state() == "available" ? "Available" : info.state());
        agent.set_type_name(info.interface());
        agent.set_host(info.owner());
        agent.set_origin(origin);
        components.push_back(agent);
      }
      if (info.name() == "camus.registry") continue;  // registering is a SAM's business
      const gp::ServiceDescriptor* interface = decoder_.pool().find_service(info.interface());
      if (interface == nullptr) continue;
      for (int i = 0; i < interface->method_count(); ++i) {
        const gp::MethodDescriptor* method = interface->method(i);
        Operation operation;
        operation.name = info.name() + "/" + method->name();
        operation.type = method->full_name();
        operation.space = options_.space;
        operation.service = info.name();
        operation.request = method->input_type();
        operation.response = method->output_type();
        operation.handler = [this, name = info.name(), method](const Caller& caller, std::string json,
                                                               std::function<void(CallReply)> reply) {
          call(caller, name, *method, std::move(json), std::move(reply));
        };
        operations.push_back(std::move(operation));
      }
    }
  }
  sink_->services(kSource, std::move(services));
  sink_->components(kSource, std::move(components));
  sink_->operations(kSource, std::move(operations));
}

void CamusSource::read_context() {
  const auto listed =
      client_->call("camus.context", "List", camus::ContextListRequest().SerializeAsString(), options_.read_timeout);
  camus::ContextListReply list;
  if (!listed.ok() || !list.ParseFromString(listed.payload)) {
    spdlog::warn("gateway: reading the context of {} failed: {}", options_.space, listed.message);
    return;
  }
  for (const camus::ContextEntry& entry : list.entries()) sink_->context(entry_of(options_.space, entry));
}

void CamusSource::on_event(const planet::Event& event) {
  const std::string& topic = event.topic();
  if (topic.rfind("registry/", 0) == 0) poller_.wake();
  if (topic.rfind("context/", 0) == 0) {
    camus::ContextEntry entry;
    if (entry.ParseFromString(event.payload())) {
      ContextEntry out = entry_of(options_.space, entry);
      // Deleting or expiring a key publishes its entry with a null value.
      out.set_removed(entry.value().kind_case() == gp::Value::kNullValue);
      sink_->context(out);
    }
    return;  // on /context, not repeated on /events
  }
  Event out;
  out.set_space(options_.space);
  out.set_seq(static_cast<double>(event.seq()));
  out.set_topic(topic);
  out.set_source(event.source());
  out.set_content_type(event.content_type());
  out.set_stamp(static_cast<double>(event.time_unix_ns()) / 1e9);
  *out.mutable_payload() = decoder_.decode(event.content_type(), event.payload());
  sink_->event(out);
}

void CamusSource::call(const Caller& caller, const std::string& service, const gp::MethodDescriptor& method,
                       std::string json, std::function<void(CallReply)> reply) {
  std::shared_ptr<const Login> login = logins_.find(caller.login);
  if (!login || !login->client) {
    reply(CallReply::failure("UNAUTHENTICATED: this connection's login ended; log in again"));
    return;
  }
  auto request = decoder_.pool().new_message(*method.input_type());
  const std::string error = schema::json_to_message(json.empty() ? "{}" : json, *request);
  if (!error.empty()) {
    reply(CallReply::failure("BAD_ARGUMENTS: " + error));
    return;
  }
  if (schema::is_oneway(method)) {
    if (!login->client->oneway(service, method.name(), request->SerializeAsString())) {
      reply(CallReply::failure("UNAVAILABLE: the session's queue is full"));
    } else {
      reply(CallReply::success("{}"));
    }
    return;
  }
  const gp::Descriptor* output = method.output_type();
  login->client->call_async(
      service, method.name(), request->SerializeAsString(), std::chrono::milliseconds(0),
      [this, output, reply = std::move(reply)](planet::CallResult result) {
        if (result.ok()) {
          auto message = decoder_.pool().new_message(*output);
          std::string text;
          if (!message->ParseFromString(result.payload) || !schema::message_to_json(*message, text).empty()) {
            reply(CallReply::failure("INTERNAL: the reply is not a valid " + output->full_name()));
          } else {
            reply(CallReply::success(std::move(text)));
          }
          return;
        }
        std::string why = std::string(planet::status_name(result.status));
        if (result.status == planet::USER_EXCEPTION) {
          why += " " + result.exception_type + " " + decoder_.decode_json(result.exception_type, result.payload);
        }
        if (!result.message.empty()) why += ": " + result.message;
        reply(CallReply::failure(std::move(why)));
      });
}

}  // namespace urs::gateway
