#include "camus_stand_ins.hpp"

#include <spdlog/spdlog.h>

#include "urs/agent/camus.hpp"

namespace urs::bridge {

CamusStandIns::CamusStandIns(agent::AgentHost& host, planet::Client* client, std::string bridge,
                             MakeForwarder forwarder)
    : host_(host), client_(client), bridge_(std::move(bridge)), forwarder_(std::move(forwarder)) {}

std::map<std::string, std::string> CamusStandIns::properties_of(const core::Route& route) const {
  std::map<std::string, std::string> properties = route.offer.properties;
  properties[kOriginProperty] = route.offer.source;
  properties[kBridgeProperty] = bridge_;
  return properties;
}

void CamusStandIns::register_service(const agent::HostedService& hosted, const std::string& what) {
  if (!client_) return;
  client_->register_service(agent::registration(hosted), [name = hosted.name, what](planet::CallResult result) {
    if (result.ok()) {
      spdlog::info("bridge: {} offered to CAMUS as {}", what, name);
    } else {
      spdlog::error("bridge: offering {} as {} failed: {}: {}", what, name, planet::status_name(result.status),
                    result.message);
    }
  });
}

core::OfferOutcome CamusStandIns::offer(const core::Route& route) {
  agent::HostedService hosted{route.name, forwarder_(route), properties_of(route), route.deadline_ms};
  host_.add(hosted);  // throws std::invalid_argument for a name it hosts already
  register_service(hosted, route.offer.name);
  return core::OfferOutcome::done();
}

void CamusStandIns::withdraw(const core::Route& route) {
  spdlog::info("bridge: withdrawing {} from CAMUS (stood for {})", route.name, route.offer.name);
  if (client_) client_->unregister_service(route.name);
  host_.remove(route.name);
}

void CamusStandIns::update(const core::Route& route) {
  const agent::HostedService* hosted = host_.find(route.name);
  if (hosted == nullptr) return;
  agent::HostedService updated = *hosted;
  updated.properties = properties_of(route);
  const auto health = updated.properties.find(kHealthProperty);
  if (health != updated.properties.end()) spdlog::info("bridge: {} is {} ({})", route.name, health->second, route.offer.name);
  // Registering again under the same name replaces the registry's entry.
  if (client_) client_->register_service(agent::registration(updated));
}

}  // namespace urs::bridge
