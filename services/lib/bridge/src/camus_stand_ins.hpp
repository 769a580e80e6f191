#pragma once
// CamusStandIns: the CAMUS side's ServiceOffering (internal). A route's stand-in is a service
// named route.name hosted on the session's AgentHost (the agent the source side's adapter makes)
// and registered with the CAMUS server when there is one, with the properties
// urslink.origin=<offer source>, urslink.bridge=<bridge> and the offer's. A change of the offer's
// properties registers it again (same name: the registry's entry is replaced). The Planet client
// registers again by itself what it registered, after a reconnect.

#include <string>

#include "forwarding.hpp"
#include "urs/agent/agent.hpp"
#include "urs/bridge/core/route_reconciler.hpp"
#include "urs/planet/client.hpp"

namespace urs::bridge {

class CamusStandIns : public core::ServiceOffering {
 public:
  // `host` and `client` (null: no CAMUS server, nothing registered) outlive this.
  CamusStandIns(agent::AgentHost& host, planet::Client* client, std::string bridge, MakeForwarder forwarder);

  // core::ServiceOffering
  core::OfferOutcome offer(const core::Route& route) override;
  void withdraw(const core::Route& route) override;
  void update(const core::Route& route) override;

 private:
  std::map<std::string, std::string> properties_of(const core::Route& route) const;
  void register_service(const agent::HostedService& hosted, const std::string& what);

  agent::AgentHost& host_;
  planet::Client* client_;
  const std::string bridge_;
  const MakeForwarder forwarder_;
};

}  // namespace urs::bridge
