#pragma once
// The sides urs-bridge is made of and the directions between them, from its configuration: the
// one place that names every middleware (docs/architecture.md, "Add a side"). The core
// (urs/bridge/core/bridge.hpp) runs what compose() returns.

#include <memory>
#include <optional>
#include <vector>

#include "urs/bridge/config.hpp"
#include "urs/bridge/core/bridge.hpp"
#include "urs/planet/client.hpp"
#include "urs/rtc/manager.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/schema/interface_catalog.hpp"

namespace urs::bridge {

// What the process has for the sides; each outlives the bridge.
struct SideResources {
  const schema::InterfaceCatalog& catalog;
  // The RT side: all three, or none (a space without a naming service: no ORB is needed).
  rtc::Orb* orb = nullptr;
  rtc::NamingClient* naming = nullptr;
  rtc::Manager* manager = nullptr;
  // The CAMUS side: the server's address and the credential (nullopt: a space without one).
  std::optional<planet::ClientOptions> planet;
};

struct Composition {
  std::vector<std::unique_ptr<core::Side>> sides;
  core::BridgeLayout layout;
};

// The sides `config` and `resources` call for (rt: naming service given; camus: CAMUS server
// given; dds: a dds section) and the directions, state and stream flows between them:
//
//   rt -> camus     rt_to_camus.providers (then every provider connected by hand), every poll_ms
//   camus -> rt     camus_to_rt.services, on registry changes and every camus_to_rt.poll_ms
//   dds -> camus    dds.import (as_camus), on catalog changes and once a lease
//   dds -> rt       dds.import (as_rtc)
//   rt -> dds       rt_to_camus.providers, named as on CAMUS, filtered by dds.export
//   camus -> dds    dds.export
//   state           rt -> dds (dds.state.components), camus -> dds, dds -> camus (dds.state.import)
//   streams         rt -> camus (data_to_camus), camus -> rt (events_to_rt)
//
// Throws util::ConfigError listing every setting the given sides cannot serve.
Composition compose(const BridgeConfig& config, const SideResources& resources);

}  // namespace urs::bridge
