#include "rt_stand_ins.hpp"

#include <spdlog/spdlog.h>

#include <cctype>

#include "urs/corba_agent/agent_component.hpp"

namespace urs::bridge {

RtStandIns::RtStandIns(rtc::Manager& manager, std::string bridge) : manager_(manager), bridge_(std::move(bridge)) {}

std::string RtStandIns::usable_name(const std::string& name) {
  std::string out = name;
  for (char& c : out) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') c = '_';
  }
  return out;
}

core::OfferOutcome RtStandIns::offer(const core::Route& route, core::ServiceSource& from) {
  std::shared_ptr<agent::ServiceAgent> forwarder = from.serve(route);
  const std::string type_name = from.kind();
  rtc::ComponentSpec spec;
  spec.type = type_name;
  spec.instance_name = route.name;
  spec.properties = {{core::kOriginProperty, route.offer.source}, {core::kBridgeProperty, bridge_}};
  for (const auto& property : route.offer.properties) spec.properties.push_back(property);
  const auto deadline = std::chrono::milliseconds(route.deadline_ms);
  rtc::Component& created =
      manager_.create(spec, [forwarder, deadline, type = type_name](const YAML::Node&, const rtc::ComponentEnv&) {
        corba_agent::AgentComponentConfig settings;
        settings.type_name = type;
        settings.deadline = deadline;
        return std::make_unique<corba_agent::AgentComponent>(settings, forwarder);
      });
  const std::string path = manager_.naming_path(created);
  {
    std::lock_guard lock(mutex_);
    by_source_[route.offer.source] = {&created, path};
  }
  spdlog::info("bridge: {} offered to RT consumers as {}", route.offer.name, path);
  return core::OfferOutcome::done();
}

void RtStandIns::withdraw(const core::Route& route) {
  StandIn stand_in{};
  {
    std::lock_guard lock(mutex_);
    const auto it = by_source_.find(route.offer.source);
    if (it == by_source_.end()) return;
    stand_in = it->second;
    by_source_.erase(it);
  }
  spdlog::info("bridge: withdrawing {} (stood for {})", stand_in.path, route.offer.name);
  manager_.destroy(*stand_in.component);
}

rtc::Component* RtStandIns::find(const std::string& source) const {
  std::lock_guard lock(mutex_);
  const auto it = by_source_.find(source);
  return it == by_source_.end() ? nullptr : it->second.component;
}

std::vector<std::pair<std::string, rtc::Component*>> RtStandIns::components() const {
  std::lock_guard lock(mutex_);
  std::vector<std::pair<std::string, rtc::Component*>> out;
  for (const auto& [source, stand_in] : by_source_) out.emplace_back(source, stand_in.component);
  return out;
}

std::vector<std::string> RtStandIns::paths() const {
  std::lock_guard lock(mutex_);
  std::vector<std::string> out;
  for (const auto& [source, stand_in] : by_source_) out.push_back(stand_in.path);
  return out;
}

}  // namespace urs::bridge
