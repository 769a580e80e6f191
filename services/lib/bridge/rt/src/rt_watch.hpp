#pragma once
// RtWatch: the RT side's watch of the naming service (internal; docs/bridge.md "RT side"), as a
// connector does (the documented steps of rtc::Connector, with the bridge RTC as the
// one consumer): the components some rule concerns are read, probed and their ports connected to
// the bridge RTC's ports (provider ports to "providers", data ports to in<N>/out<N>); a component
// that vanished, was rebound or stopped answering has its connections dropped on both ends; one
// that is merely slow is kept and marked. Every connection it drops is dropped on both ends.
//
// What it gives RtSide: the provider interfaces connected to "providers" as offers (whoever
// connected them: the watch, `urs rtc con`, rtcon), and a forwarding agent for each
// (corba_agent::CorbaProxyAgent, calls by DII).
//
// Threads: the bridge's thread only. Lives as long as the bridge RTC (across sessions).

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "bridge_component.hpp"
#include "urs/agent/agent.hpp"
#include "urs/bridge/core/route_reconciler.hpp"
#include "urs/bridge/core/state.hpp"
#include "urs/bridge/rt/rt_side.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/schema/interface_catalog.hpp"

namespace urs::bridge {

class RtWatch {
 public:
  // All outlive the watch; `own_path` is the bridge RTC's naming path (never watched).
  RtWatch(rtc::Orb& orb, rtc::NamingClient& naming, const schema::InterfaceCatalog& catalog, const RtSideConfig& config,
          BridgeComponent& component, std::string own_path);

  // One pass of the naming watch. `every_component`: read every RTC (their states are shared),
  // not only those a rule concerns.
  void watch(bool every_component);

  // The provider interfaces connected to the bridge RTC's "providers" port, whose IDL the bridge
  // knows: key "<connector id>|<published key>", name the provider's naming path, fields
  // {instance} {port} {interface} {host}, properties rtc.type_name, urslink.health, rtc.state.
  std::vector<core::Offer> provider_offers();
  // The agent forwarding calls to the provider of an offer of provider_offers() (throws if that
  // connection is gone).
  std::shared_ptr<agent::ServiceAgent> forwarder(const core::Route& route);

  // The lifecycle states of the RTCs watched (not the bridges' own), as last read.
  std::vector<core::ComponentState> component_states() const;

 private:
  struct Known;  // a component found in the naming service

  // Drops one connection the bridge made, on both ends: notify_disconnect on the peer's port
  // (best effort, bounded), then our port's half.
  void drop_link(const Known& known, const std::string& link, const std::string& connector_id);
  // Drops, on `peer`, the connections listing `ours` that `ours` no longer holds; returns how many.
  int drop_stale_halves(const std::string& path, RTC::PortService_ptr peer, const std::string& peer_name,
                        rtc::PortBase& ours);
  void connect_wanted(const std::string& path, Known& known);
  // urslink.health and rtc.state of an RT provider, from what the last watch saw of its component.
  void add_health(std::map<std::string, std::string>& properties, const Known& known) const;
  // For CorbaProxyOptions::explain_missing_target: the state of the component at `path` (IOR
  // `ior`) when it is why its provider does not exist; empty if not.
  std::function<std::string()> owner_state_check(const std::string& path, const std::string& ior) const;

  rtc::Orb& orb_;
  rtc::NamingClient& naming_;
  const schema::InterfaceCatalog& catalog_;
  const RtSideConfig& config_;
  BridgeComponent& component_;
  const std::string own_path_;
  std::map<std::string, std::shared_ptr<Known>> known_;  // by naming path
  std::set<std::string> warned_;                         // problems logged once
};

}  // namespace urs::bridge
