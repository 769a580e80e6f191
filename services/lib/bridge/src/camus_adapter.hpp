#pragma once
// CamusAdapter: the bridge's CAMUS side (internal; docs/bridge.md). One per session: the Planet
// session (a SAM-role client; none for a space without a CAMUS server) and the AgentHost of the
// forwarding agents that stand for other sides' services (CamusStandIns; they are also what other
// spaces' calls reach, DdsAdapter). What it gives the core: the registry's services as offers,
// and a forwarding agent for each (CamusForwardingAgent). Besides routes it carries the data relay:
// values of the bridge RTC's in<N> published as CAMUS events (and context), and the events of
// events_to_rt written to out<N>.
//
// Threads: list_services(), forwarder(), description() block on the registry: the bridge's
// thread only. relay() runs on the RT ports' threads.

#include <google/protobuf/dynamic_message.h>

#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "forwarding.hpp"
#include "urs/agent/agent.hpp"
#include "urs/bridge/config.hpp"
#include "urs/bridge/interfaces.hpp"
#include "urs/corba_agent/agent_component.hpp"
#include "urs/planet/client.hpp"
#include "urs/schema/schema.hpp"

namespace urs::bridge {

class CamusAdapter {
 public:
  // `options` nullopt: no CAMUS server (the agents are hosted for the other spaces only). Its peer
  // name and role are set by the Bridge. `event_ports[i]` is where events_to_rt[i]'s events go.
  // `config` and `catalog` outlive the adapter.
  CamusAdapter(const BridgeConfig& config, const InterfaceCatalog& catalog,
               const std::optional<planet::ClientOptions>& options, std::vector<corba_agent::RawOutPort*> event_ports);
  ~CamusAdapter();  // stop()
  CamusAdapter(const CamusAdapter&) = delete;
  CamusAdapter& operator=(const CamusAdapter&) = delete;

  // Starts the host, subscribes the events_to_rt topics and connects (returns at once).
  void start();
  // Unsubscribes, stops the host (queued calls answered UNAVAILABLE), the client and the event
  // writer. Idempotent.
  void stop();

  planet::Client* client() { return client_.get(); }
  agent::AgentHost& host() { return host_; }

  // A service of the registry, as an offer (key and name: the service name; fields {service};
  // origin: its urslink.origin; built_in: the server's camus.*) with what the registry says of it.
  struct Service {
    core::Offer offer;
    std::string owner;         // its SAM
    uint32_t deadline_ms = 0;  // advertised (0: the server's)
  };
  // The registry's available services but this bridge's own. nullopt if the registry cannot be
  // read now (logged once) or there is no CAMUS server.
  std::optional<std::vector<Service>> list_services();
  // A CamusForwardingAgent for the CAMUS service of route.offer, its interface described by the
  // registry (throws with the registry's answer if it cannot be).
  std::shared_ptr<agent::ServiceAgent> forwarder(const core::Route& route);
  // The descriptor set of a CAMUS service, from the registry, kept (services of one interface
  // share it); null if the registry cannot say now.
  std::shared_ptr<const std::string> description(const std::string& service);
  // A value that arrived at in<entry>: published on data_to_camus[entry]'s topic (and context).
  void relay(std::size_t entry, const google::protobuf::Message& value);

 private:
  void subscribe_events();

  const BridgeConfig& config_;
  const InterfaceCatalog& catalog_;
  const std::vector<corba_agent::RawOutPort*> event_ports_;
  std::unique_ptr<planet::Client> client_;
  std::unique_ptr<agent::EventSink> sink_;
  google::protobuf::DynamicMessageFactory factory_;
  agent::AgentHost host_;  // after factory_ and sink_, which it uses
  schema::SchemaPool described_interfaces_;  // interfaces of CAMUS services, from the registry
  // A descriptor set is some kB; the services of one interface share theirs.
  struct ByContent {
    bool operator()(const std::shared_ptr<const std::string>& a, const std::shared_ptr<const std::string>& b) const {
      return *a < *b;
    }
  };
  std::set<std::shared_ptr<const std::string>, ByContent> descriptions_;  // each distinct descriptor set
  std::map<std::string, std::shared_ptr<const std::string>> described_;  // CAMUS service -> its descriptor set
  std::vector<uint64_t> subscriptions_;
  bool warned_registry_ = false;
  bool stopped_ = false;
  // Writes events to RT InPorts one at a time, in order, off the Planet client's thread, so a
  // slow InPort (flush: each write waits for the peer) never holds up the session.
  agent::WorkerPool event_writer_{1};
};

}  // namespace urs::bridge
