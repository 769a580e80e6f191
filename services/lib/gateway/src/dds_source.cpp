#include "urs/gateway/dds_source.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <set>

#include "urs/gateway/gateway.hpp"

namespace urs::gateway {

namespace {
constexpr const char* kSource = "dds";
}

DdsSource::DdsSource(DdsSourceOptions options) : options_(std::move(options)), link_retry_("gateway") {}

DdsSource::~DdsSource() { stop(); }

std::string DdsSource::reader_name(const std::string& space) { return "urs-gateway." + space; }

void DdsSource::start(ViewSink& sink) {
  sink_ = &sink;
  join();
  // Once joined, the catalog is read when DDS says it changed and at least twice a lease;
  // until then each round tries to join again.
  poller_.start(std::min<std::chrono::milliseconds>(options_.link.lease / 2, federation::LinkRetry::kPeriod), [this] {
    if (!link_ && link_retry_.due(federation::LinkRetry::Clock::now())) join();
    if (link_) read_catalog();
  });
}

// Joins the link's domain. A link that cannot be joined yet (an initial peer or discovery server
// whose name resolves only once its container has started) leaves the gateway serving what its
// other sources show; the poller tries again every LinkRetry::kPeriod.
void DdsSource::join() {
  federation::DdsOptions link = options_.link;
  link.space = reader_name(options_.space);
  link.bridge = "urs-gateway";
  try {
    link_ = std::make_unique<federation::DdsLink>(
        link, [this] { poller_.wake(); },
        [](call::Request request, call::Responder responder) {
          // Nobody calls a gateway over DDS (it announces nothing); refuse whatever arrives.
          responder.reply(
              call::Reply::error(call::Status::UNKNOWN_SERVICE, "urs-gateway serves no " + request.service));
        });
    state_ = std::make_unique<federation::StateLink>(*link_, state_handlers(), std::nullopt);
  } catch (const std::exception& e) {
    state_.reset();
    link_.reset();
    link_retry_.failed(e.what());
    return;
  }
  link_retry_.joined();
}

// What the state topics report, into the sink.
federation::StateHandlers DdsSource::state_handlers() {
  federation::StateHandlers handlers;
  handlers.component = [this](const federation::ComponentState& state, bool alive) { component(state, alive); };
  handlers.pose = [this](const federation::SpacePose& pose) {
    if (!wanted(pose.space, options_.own_poses)) return;
    sink_->pose(pose_of(pose.space, pose.robot, pose.x, pose.y, pose.theta, pose.stamp, "dds"));
  };
  handlers.context = [this](const federation::ContextState& entry, bool alive) {
    if (!wanted(entry.space, options_.own_state)) return;
    ContextEntry out;
    out.set_space(entry.space);
    out.set_key(entry.key);
    *out.mutable_value() = json_value(entry.value_json);
    out.set_source(entry.source);
    out.set_version(static_cast<double>(entry.version));
    out.set_stamp(unix_seconds(entry.stamp));
    out.set_removed(!alive);
    sink_->context(out);
  };
  handlers.event = [this](const federation::SpaceEvent& event) {
    if (!wanted(event.space, options_.own_state)) return;
    Event out;
    out.set_space(event.space);
    out.set_seq(static_cast<double>(event.seq));
    out.set_topic(event.topic);
    out.set_source(event.source);
    out.set_content_type(event.content_type);
    out.set_stamp(unix_seconds(event.stamp));
    *out.mutable_payload() = decoder_.decode(event.content_type, event.payload);
    sink_->event(out);
  };
  return handlers;
}

void DdsSource::stop() {
  poller_.stop();
  state_.reset();
  link_.reset();
}

void DdsSource::read_catalog() {
  std::vector<Service> services;
  std::set<std::string> described;
  for (const federation::ServiceEntry& entry : link_->catalog()) {
    if (!wanted(entry.space, options_.own_services)) continue;
    // The descriptions decode the spaces' events; each digest's bytes are added once.
    if (described.insert(entry.interface_name).second && !decoder_.pool().find_service(entry.interface_name)) {
      const std::string error = decoder_.pool().add_descriptor_set(entry.descriptor_set);
      if (!error.empty())
        spdlog::debug("gateway: the description of {} from {}: {}", entry.interface_name, entry.space, error);
    }
    Service service;
    service.set_space(entry.space);
    service.set_name(entry.name);
    service.set_interface(entry.interface_name);
    service.set_origin(entry.origin);
    service.set_provider(entry.origin);
    service.set_bridge(entry.bridge);
    service.set_state("available");
    service.set_seen_via("dds");
    services.push_back(std::move(service));
  }
  sink_->services(kSource, std::move(services));
}

void DdsSource::component(const federation::ComponentState& state, bool alive) {
  if (!wanted(state.space, options_.own_services)) return;
  std::vector<Component> now;
  {
    std::lock_guard lock(components_mutex_);
    const auto key = std::make_pair(state.space, state.name);
    if (!alive) {
      components_.erase(key);
    } else {
      Component& component = components_[key];
      component.set_space(state.space);
      component.set_name(state.name);
      component.set_kind(state.kind);
      component.set_state(state.state);
      component.set_type_name(state.type_name);
      component.set_host(state.host);
    }
    for (const auto& [key_, component] : components_) now.push_back(component);
  }
  sink_->components(kSource, std::move(now));
}

}  // namespace urs::gateway
