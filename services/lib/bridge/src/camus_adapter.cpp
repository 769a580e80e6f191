#include "camus_adapter.hpp"

#include <spdlog/spdlog.h>

#include "camus.pb.h"
#include "urs/agent/client_sink.hpp"
#include "urs/agent/camus.hpp"
#include "urs/bridge/camus_forwarding_agent.hpp"
#include "urs/schema/json.hpp"

namespace urs::bridge {

namespace gp = google::protobuf;

namespace {

constexpr auto kCamusTimeout = std::chrono::milliseconds(2000);  // a registry call

// Where the forwarding agents' events go when the bridge has no CAMUS server.
class NoEvents : public agent::EventSink {
 public:
  call::Reply publish(const std::string& topic, const gp::Message&) override {
    return call::Reply::error(call::Status::UNAVAILABLE, "no CAMUS server: event on " + topic + " not published");
  }
};

gp::DynamicMessageFactory& delegating(gp::DynamicMessageFactory& factory) {
  factory.SetDelegateToGeneratedFactory(true);
  return factory;
}

}  // namespace

CamusAdapter::CamusAdapter(const BridgeConfig& config, const InterfaceCatalog& catalog,
                           const std::optional<planet::ClientOptions>& options,
                           std::vector<corba_agent::RawOutPort*> event_ports)
    : config_(config),
      catalog_(catalog),
      event_ports_(std::move(event_ports)),
      client_(options ? std::make_unique<planet::Client>(*options) : nullptr),
      sink_(client_ ? std::unique_ptr<agent::EventSink>(std::make_unique<agent::ClientEventSink>(*client_))
                    : std::make_unique<NoEvents>()),
      host_(config.workers, *sink_, &delegating(factory_)) {}

CamusAdapter::~CamusAdapter() { stop(); }

void CamusAdapter::start() {
  if (client_) {
    agent::serve_requests(*client_, host_);
    client_->on_connected([this](const planet::Welcome& welcome) {
      spdlog::info("bridge {}: connected to the CAMUS server of space {}", config_.name, welcome.space());
    });
    client_->on_disconnected([this](const std::string& reason) {
      spdlog::warn("bridge {}: lost the CAMUS server: {}; reconnecting", config_.name, reason);
    });
    subscribe_events();
    client_->start();
  }
  host_.start();
}

void CamusAdapter::subscribe_events() {
  for (std::size_t i = 0; i < config_.events_to_rt.size() && i < event_ports_.size(); ++i) {
    const EventsToRt& entry = config_.events_to_rt[i];
    const gp::Descriptor* type = catalog_.find_message(entry.type);
    corba_agent::RawOutPort* port = event_ports_[i];
    auto factory = std::make_shared<gp::DynamicMessageFactory>();
    factory->SetDelegateToGeneratedFactory(true);
    agent::WorkerPool* writer = &event_writer_;
    subscriptions_.push_back(client_->subscribe(entry.topic, [writer, type, port, factory](const planet::Event& event) {
      if (event.content_type() != type->full_name()) {
        spdlog::debug("bridge: event on {} is a {}, not {}; not sent to {}", event.topic(), event.content_type(),
                      type->full_name(), port->name());
        return;
      }
      std::shared_ptr<gp::Message> value(factory->GetPrototype(type)->New());
      if (!value->ParseFromString(event.payload())) {
        spdlog::warn("bridge: event {} on {} is not a valid {}; not sent to {}", event.seq(), event.topic(),
                     type->full_name(), port->name());
        return;
      }
      writer->post([port, value, seq = event.seq(), topic = event.topic()](bool cancelled) {
        if (cancelled) {
          spdlog::warn("bridge: deactivated before event {} on {} went out through {}", seq, topic, port->name());
          return;
        }
        try {
          const auto result = port->write(*value);
          if (result.refused > 0) {
            spdlog::warn("bridge: event {} on {}: {} InPort(s) of {} refused it", seq, topic, result.refused,
                         port->name());
          }
        } catch (const std::exception& e) {
          spdlog::warn("bridge: event {} on {} cannot go out through {}: {}", seq, topic, port->name(), e.what());
        }
      });
    }));
  }
}

void CamusAdapter::stop() {
  if (stopped_) return;
  stopped_ = true;
  if (client_) {
    for (uint64_t id : subscriptions_) client_->unsubscribe(id);
  }
  host_.stop();
  if (client_) client_->stop();
  event_writer_.stop();
}

std::optional<std::vector<CamusAdapter::Service>> CamusAdapter::list_services() {
  if (!client_) return std::nullopt;
  camus::ListRequest request;
  const auto result = client_->call("camus.registry", "List", request.SerializeAsString(), kCamusTimeout);
  camus::ListReply reply;
  if (!result.ok() || !reply.ParseFromString(result.payload)) {
    if (!warned_registry_) {
      spdlog::warn("bridge: cannot list the CAMUS registry: {} {}", planet::status_name(result.status), result.message);
    }
    warned_registry_ = true;
    return std::nullopt;
  }
  warned_registry_ = false;
  std::vector<Service> services;
  for (const auto& info : reply.services()) {
    if (info.state() != "available" || info.owner() == config_.name) continue;
    core::Offer offer;
    offer.key = info.name();
    offer.name = info.name();
    offer.interface_name = info.interface();
    const auto origin = info.properties().find(kOriginProperty);
    if (origin != info.properties().end()) offer.origin = origin->second.empty() ? "(empty)" : origin->second;
    offer.built_in = info.name().compare(0, 6, "camus.") == 0;  // the server's own services
    offer.fields = {{"service", info.name()}};
    offer.source = "camus:" + info.name();
    services.push_back({std::move(offer), info.owner(), info.deadline_ms()});
  }
  return services;
}

std::shared_ptr<agent::ServiceAgent> CamusAdapter::forwarder(const core::Route& route) {
  if (!client_) throw std::runtime_error("no CAMUS server");
  std::string error;
  const gp::ServiceDescriptor* interface =
      describe_service(*client_, route.offer.name, described_interfaces_, kCamusTimeout, error);
  if (interface == nullptr) throw std::runtime_error(error);
  return std::make_shared<CamusForwardingAgent>(*client_, route.offer.name, *interface);
}

std::shared_ptr<const std::string> CamusAdapter::description(const std::string& service) {
  const auto known = described_.find(service);
  if (known != described_.end()) return known->second;
  if (!client_) return nullptr;
  camus::DescribeRequest request;
  request.set_service(service);
  const auto result = client_->call("camus.registry", "Describe", request.SerializeAsString(), kCamusTimeout);
  camus::DescribeReply reply;
  if (!result.ok() || !reply.ParseFromString(result.payload)) return nullptr;
  const auto description = *descriptions_.insert(std::make_shared<const std::string>(reply.descriptor_set())).first;
  described_.emplace(service, description);
  return description;
}

void CamusAdapter::relay(std::size_t entry, const gp::Message& value) {
  const DataToCamus& config = config_.data_to_camus.at(entry);
  if (!client_) return;
  const auto published = client_->publish(config.topic, value.SerializeAsString(), value.GetTypeName());
  if (!published.ok()) {
    spdlog::warn("bridge: value for {} not published: {}", config.topic, published.message);
  }
  if (config.context.empty()) return;
  std::string json;
  camus::ContextSetRequest request;
  request.set_key(config.context);
  request.set_source(config_.name);
  std::string error = schema::message_to_json(value, json);
  if (error.empty()) error = schema::json_to_message(json, *request.mutable_value());
  if (!error.empty()) {
    spdlog::warn("bridge: value for context {} cannot be converted: {}", config.context, error);
    return;
  }
  client_->call_async("camus.context", "Set", request.SerializeAsString(), kCamusTimeout,
                      [key = config.context](planet::CallResult result) {
                        if (!result.ok()) spdlog::warn("bridge: context {} not set: {}", key, result.message);
                      });
}

}  // namespace urs::bridge
