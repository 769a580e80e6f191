#include "urs/bridge/rt/rt_side.hpp"

#include <spdlog/spdlog.h>

#include <cctype>

#include "bridge_component.hpp"
#include "connection_keeper.hpp"
#include "rt_stand_ins.hpp"
#include "rt_watch.hpp"
#include "urs/bridge/core/route_reconciler.hpp"
#include "urs/rtc/execution_context.hpp"
#include "urs/rtc/tools.hpp"
#include "urs/schema/schema.hpp"
#include "urs/util/error.hpp"

namespace urs::bridge {

namespace gp = google::protobuf;

namespace {

constexpr const char* kConnectorName = "urs-bridge";  // profile name prefix of the connections the watch makes

// The types of `rules`' values, checked to be IDL structs, exceptions or unions the catalog knows.
std::vector<const gp::Descriptor*> port_types(const schema::InterfaceCatalog& catalog,
                                              const std::vector<DataPortRule>& rules, const std::string& key,
                                              std::vector<std::string>& errors) {
  std::vector<const gp::Descriptor*> types;
  for (std::size_t i = 0; i < rules.size(); ++i) {
    const std::string where = key + "[" + std::to_string(i) + "].type";
    const gp::Descriptor* found = catalog.find_message(rules[i].type);
    if (found == nullptr) {
      errors.push_back(where + ": no message type " + rules[i].type + " is known (add its IDL under idl:)");
    } else if (schema::repository_id(*found).empty()) {
      errors.push_back(where + ": " + rules[i].type + " is not an IDL struct, exception or union");
    }
    types.push_back(found);
  }
  return types;
}

}  // namespace

RtSide::RtSide(rtc::Orb& orb, rtc::NamingClient& naming, rtc::Manager& manager, const schema::InterfaceCatalog& catalog,
               RtSideConfig config)
    : core::Side("rt"), orb_(orb), naming_(naming), manager_(manager), catalog_(catalog), config_(std::move(config)) {
  std::vector<std::string> errors;
  port_types(catalog_, config_.in, "data_to_camus", errors);
  port_types(catalog_, config_.out, "events_to_rt", errors);
  if (!errors.empty()) {
    std::string text = "RT side:";
    for (const auto& error : errors) text += "\n  " + error;
    throw util::ConfigError(text);
  }
}

RtSide::~RtSide() { stop(); }

void RtSide::start(core::SideEvents& events) {
  {
    std::lock_guard lock(events_mutex_);
    events_ = &events;
  }
  std::vector<std::string> unused;
  auto in_types = port_types(catalog_, config_.in, "data_to_camus", unused);
  auto out_types = port_types(catalog_, config_.out, "events_to_rt", unused);
  rtc::ComponentSpec spec;
  spec.type = "Bridge";
  spec.instance_name = config_.instance;
  spec.properties = {{core::kBridgeProperty, config_.bridge}};
  rtc::Component& created = manager_.create(spec, [&](const YAML::Node&, const rtc::ComponentEnv&) {
    BridgeComponent::Hooks hooks{[this](bool active) {
                                   std::lock_guard lock(events_mutex_);
                                   if (events_ != nullptr) events_->set_active(active);
                                 },
                                 [this](std::size_t entry, const gp::Message& value) {
                                   std::lock_guard lock(stream_mutex_);
                                   if (stream_sink_ != nullptr) stream_sink_->write(entry, value);
                                 }};
    auto component = std::make_unique<BridgeComponent>(config_.bridge, in_types, out_types, std::move(hooks));
    component_ = component.get();
    return component;
  });
  path_ = manager_.naming_path(created);
  watch_ = std::make_unique<RtWatch>(orb_, naming_, catalog_, config_, *component_, path_);
  stand_ins_ = std::make_unique<RtStandIns>(manager_, config_.bridge);
  connections_ = std::make_unique<ConnectionKeeper>(orb_, config_.connections_file,
                                                    std::string(kConnectorName) + "." + config_.bridge);
  if (config_.activate) {
    RTC::RTObject_var self = created.reference();
    RTC::ExecutionContextService_var context = created.execution_context().reference();
    const RTC::ReturnCode_t result = context->activate_component(self);
    if (result != RTC::RTC_OK) {
      throw util::Unavailable(path_ + ": activation returned " + rtc::return_code_name(result));
    }
  }
}

void RtSide::stop() {
  std::lock_guard lock(events_mutex_);
  events_ = nullptr;  // the RTC's lifecycle no longer drives anything
}

void RtSide::open() { connections_->load(); }

RtSide::Clock::time_point RtSide::poll(Clock::time_point now) {
  watch_->watch(state_sink_ != nullptr);  // every RTC's state is shared
  connections_->restore([this](const std::string& key) -> rtc::Component* {
    for (const auto& [rtc_key, component] : our_rtcs()) {
      if (rtc_key == key) return component;
    }
    return nullptr;
  });
  connections_->save(our_rtcs());
  if (state_sink_ != nullptr && now - states_read_at_ >= config_.state_period) {
    states_read_at_ = now;
    state_sink_->components("rtc", watch_->component_states());
  }
  return now + config_.poll;
}

std::vector<std::pair<std::string, rtc::Component*>> RtSide::our_rtcs() const {
  std::vector<std::pair<std::string, rtc::Component*>> rtcs{{"bridge", component_}};
  for (const auto& entry : stand_ins_->components()) rtcs.push_back(entry);
  return rtcs;
}

std::optional<std::vector<core::Offer>> RtSide::offers() { return watch_->provider_offers(); }

std::shared_ptr<agent::ServiceAgent> RtSide::serve(const core::Route& route) { return watch_->forwarder(route); }

core::OfferOutcome RtSide::offer(const core::Route& route, core::ServiceSource& from) {
  return stand_ins_->offer(route, from);
}

void RtSide::withdraw(const core::Route& route) { stand_ins_->withdraw(route); }

std::string RtSide::usable_name(const std::string& name) const { return RtStandIns::usable_name(name); }

void RtSide::share_state(core::StateSink* sink) {
  state_sink_ = sink;
  states_read_at_ = {};
}

void RtSide::stream_to(core::StreamSink* sink) {
  std::lock_guard lock(stream_mutex_);
  stream_sink_ = sink;
}

void RtSide::write(std::size_t entry, const gp::Message& value) {
  if (component_ == nullptr || entry >= config_.out.size()) return;
  corba_agent::RawOutPort* port = &component_->out_port(entry);
  std::shared_ptr<gp::Message> copy(value.New());
  copy->CopyFrom(value);
  writer_.post([port, copy](bool cancelled) {
    if (cancelled) {
      spdlog::warn("bridge: stopping before a value went out through {}", port->name());
      return;
    }
    try {
      const auto result = port->write(*copy);
      if (result.refused > 0) spdlog::warn("bridge: {} InPort(s) of {} refused a value", result.refused, port->name());
    } catch (const std::exception& e) {
      spdlog::warn("bridge: a value cannot go out through {}: {}", port->name(), e.what());
    }
  });
}

}  // namespace urs::bridge
