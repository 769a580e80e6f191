#pragma once
// RtStandIns: the RT side's stand-ins (internal). A route's stand-in is an RT-Component in the
// naming service (corba_agent::AgentComponent, instance name route.name with characters other
// than [A-Za-z0-9_-] made '_', type the source side's kind()) with one provider port of the
// service's interface, its calls going to the agent the source side serves them with. It carries
// the component properties urslink.origin=<offer source>, urslink.bridge=<bridge>, and the offer's
// properties.

#include <map>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "urs/bridge/core/route_reconciler.hpp"
#include "urs/bridge/core/side.hpp"
#include "urs/rtc/manager.hpp"

namespace urs::bridge {

class RtStandIns {
 public:
  // `manager` outlives this.
  RtStandIns(rtc::Manager& manager, std::string bridge);

  // As core::ServiceOffering's.
  core::OfferOutcome offer(const core::Route& route, core::ServiceSource& from);
  void withdraw(const core::Route& route);
  static std::string usable_name(const std::string& name);

  // The stand-in for an offer source ("camus:<service>"), for the connections kept across
  // restarts; nullptr if there is none now. Bridge thread only.
  rtc::Component* find(const std::string& source) const;
  // (source, component) of every stand-in. Bridge thread only.
  std::vector<std::pair<std::string, rtc::Component*>> components() const;
  // The naming paths of the stand-ins; from any thread.
  std::vector<std::string> paths() const;

 private:
  struct StandIn {
    rtc::Component* component;
    std::string path;
  };
  rtc::Manager& manager_;
  const std::string bridge_;
  mutable std::mutex mutex_;  // paths() reads from other threads
  std::map<std::string, StandIn> by_source_;
};

}  // namespace urs::bridge
