#include "urs/gateway/dds_source.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <set>

#include "urs/gateway/gateway.hpp"

namespace urs::gateway {

namespace {
constexpr const char* kSource = "dds";
constexpr auto kJoinRetryPeriod = std::chrono::seconds(2);  // joining the DDS link again, as the bridge does
}

DdsSource::DdsSource(DdsSourceOptions options) : options_(std::move(options)) {}

DdsSource::~DdsSource() { stop(); }

std::string DdsSource::reader_name(const std::string& space) { return "urs-gateway." + space; }

void DdsSource::start(ViewSink& sink) {
  sink_ = &sink;
  join();
  // Once joined, the catalog is read when DDS says it changed and at least twice a lease;
  // until then each round tries to join again.
  poller_.start(std::min<std::chrono::milliseconds>(options_.link.lease / 2, kJoinRetryPeriod), [this] {
    if (!link_ && std::chrono::steady_clock::now() >= next_join_) join();
    if (link_) read_catalog();
  });
}

// Joins the link's domain. A link that cannot be joined yet (an initial peer or discovery server
// whose name resolves only once its container has started) leaves the gateway serving what its
// other sources show; the poller tries again every kJoinRetryPeriod.
void DdsSource::join() {
  bridge::DdsOptions link = options_.link;
  link.space = reader_name(options_.space);
  link.bridge = "urs-gateway";
  try {
    link_ = std::make_unique<bridge::DdsLink>(
        link,
        [this] { poller_.wake(); },
        [](call::Request request, call::Responder responder) {
          // Nobody calls a gateway over DDS (it announces nothing); refuse whatever arrives.
          responder.reply(call::Reply::error(call::Status::UNKNOWN_SERVICE, "urs-gateway serves no " + request.service));
        });
    state_ = std::make_unique<bridge::StateLink>(*link_, state_handlers(), std::nullopt);
  } catch (const std::exception& e) {
    state_.reset();
    link_.reset();
    if (e.what() != join_failure_) {
      spdlog::error("gateway: no link to other spaces yet: {}; trying again every {} s", e.what(),
                    std::chrono::duration_cast<std::chrono::seconds>(kJoinRetryPeriod).count());
      join_failure_ = e.what();
    }
    next_join_ = std::chrono::steady_clock::now() + kJoinRetryPeriod;
    return;
  }
  if (!join_failure_.empty()) spdlog::info("gateway: joined the link to other spaces");
  join_failure_.clear();
}

// What the state topics report, into the sink.
bridge::StateHandlers DdsSource::state_handlers() {
  bridge::StateHandlers handlers;
  handlers.component = [this](const bridge::ComponentState& state, bool alive) { component(state, alive); };
  handlers.pose = [this](const bridge::SpacePose& pose) {
    if (!wanted(pose.space, options_.own_poses)) return;
    sink_->pose(pose_of(pose.space, pose.robot, pose.x, pose.y, pose.theta, pose.stamp, "dds"));
  };
  handlers.context = [this](const bridge::ContextState& entry, bool alive) {
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
  handlers.event = [this](const bridge::SpaceEvent& event) {
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
  for (const bridge::ServiceEntry& entry : link_->catalog()) {
    if (!wanted(entry.space, options_.own_services)) continue;
    // The descriptions decode the spaces' events; each digest's bytes are added once.
    if (described.insert(entry.interface_name).second && !decoder_.pool().find_service(entry.interface_name)) {
      const std::string error = decoder_.pool().add_descriptor_set(entry.descriptor_set);
      if (!error.empty()) spdlog::debug("gateway: the description of {} from {}: {}", entry.interface_name, entry.space, error);
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

void DdsSource::component(const bridge::ComponentState& state, bool alive) {
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
