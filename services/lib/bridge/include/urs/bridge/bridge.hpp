#pragma once
// The bridge (the papers' RSCM / SAM-RTC): makes the services of each world usable from the
// others, generically, from interface descriptions alone. It composes a middleware-free core and
// one adapter per side (docs/architecture.md, "The bridge"):
//
//   core    core::RouteReconciler, one per direction: from what a side offers now and the rules,
//           the routes that must exist, made and withdrawn through the target side's
//           core::ServiceOffering (include/urs/bridge/core/)
//   RT      RtAdapter (naming watch, probes, connections to the bridge RTC), RtStandIns (RTCs
//           standing for other sides' services), BridgeComponent (the bridge RTC),
//           ConnectionKeeper (its RTCs' connections across restarts)
//   CAMUS   CamusAdapter (Planet session, registry, data relay), CamusStandIns (hosted agents)
//   DDS     DdsAdapter (the other spaces' catalog, their calls, the shared state)
//
// The routes, each a reconciler (source offers -> target stand-ins):
//   RT provider -> CAMUS     provider ports connected to the bridge RTC's "providers" port (rules
//                            rt_to_camus.providers) -> CorbaProxyAgents hosted and registered
//   CAMUS service -> RT      the registry's services (camus_to_rt.services) -> RTCs hosting a
//                            CamusForwardingAgent
//   other space -> CAMUS/RT  the DDS catalog (dds.import) -> agents forwarding over DdsLink
//   this space -> others     the RT providers' agents and this space's CAMUS services
//                            (dds.export) -> entries of this space's DDS catalog
//   data (not routes)        RT OutPorts feed CAMUS events (and context); CAMUS events feed RT InPorts.
//
// The bridge RTC's lifecycle drives it: activating it opens a session (the CAMUS and DDS adapters
// and the routes); deactivating it withdraws every route. While active, its thread runs the
// naming watch and the RT routes every rt_to_camus.poll_ms, the registry and the CAMUS routes
// every camus_to_rt.poll_ms, and the DDS routes when the catalog changes (once a lease anyway).
//
// Loops are prevented by origin: what the bridge offers carries "urslink.origin" (a CAMUS property
// "rtc:<path>:<port>" or "dds:<space>/<service>", a component property "camus:<service>" or
// "dds:<space>/<service>"), and nothing that carries one is bridged again (core::bridgeable).

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "urs/bridge/config.hpp"
#include "urs/bridge/interfaces.hpp"
#include "urs/bridge/link_retry.hpp"
#include "urs/planet/client.hpp"
#include "urs/rtc/manager.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"

namespace urs::bridge {

class BridgeComponent;
class ConnectionKeeper;
class RtAdapter;

struct BridgeStatus {
  bool active = false;                // a session is open
  std::vector<std::string> exported;  // CAMUS services standing for RT providers
  std::vector<std::string> imported;  // naming paths of RTCs standing for CAMUS services
  std::vector<std::string> remote;    // "<space>/<service>" of other spaces' services offered here
  std::map<std::string, std::string> health;  // CAMUS name of an RT provider -> "ok", "slow", "inactive", ...
};

class Bridge {
 public:
  // `orb`, `naming`, `manager` and `catalog` outlive the bridge. `planet` is the session's client
  // options (address, token); its peer name and role are set from the configuration. A space
  // without a naming service passes null `naming` and `manager` (no RT side, no bridge RTC: the
  // bridge is active from start()); one without a CAMUS server passes no `planet`. Throws
  // urs::util::ConfigError for configuration the sides given cannot serve.
  Bridge(rtc::Orb& orb, rtc::NamingClient* naming, rtc::Manager* manager, const InterfaceCatalog& catalog,
         BridgeConfig config, std::optional<planet::ClientOptions> planet);
  ~Bridge();  // shutdown()
  Bridge(const Bridge&) = delete;
  Bridge& operator=(const Bridge&) = delete;

  // Creates the bridge RTC through the manager (bound as <host>.host_cxt/<instance>.rtc) and starts
  // the bridge's thread; activates the RTC if the configuration says so. Throws on failure.
  // Returns the RTC (nullptr without an RT side).
  rtc::Component* start();
  // Closes the session (withdrawing everything) and stops the thread. Idempotent.
  void shutdown();

  BridgeStatus status() const;

 private:
  struct Session;  // one activation: the CAMUS and DDS adapters, the stand-ins and the routes

  void request_active(bool active);  // from the RTC's lifecycle hooks
  void run();
  void open_session();
  void close_session();
  void join_link(Session& session);  // the DDS side of the session, once the link can be joined
  // The passes of the run loop (the bridge's thread).
  void poll_rt(Session& session);
  void poll_camus(Session& session);
  void poll_dds(Session& session);
  void export_to_dds(Session& session);  // what this space offers, onto the other spaces' catalog
  void on_data(std::size_t entry, const google::protobuf::Message& value);
  // The RTCs of the bridge whose connections are kept across restarts, by ConnectionKeeper key.
  std::vector<std::pair<std::string, rtc::Component*>> our_rtcs(Session& session) const;

  rtc::Orb& orb_;
  rtc::NamingClient* naming_;
  rtc::Manager* manager_;
  const InterfaceCatalog& catalog_;
  const BridgeConfig config_;
  std::optional<planet::ClientOptions> planet_;

  BridgeComponent* component_ = nullptr;
  std::unique_ptr<RtAdapter> rt_;                 // with an RT side; lives as long as the bridge RTC
  std::unique_ptr<ConnectionKeeper> connections_;  // with an RT side

  mutable std::mutex mutex_;  // guards the fields below and session_ swaps
  std::condition_variable wake_;
  bool want_active_ = false;
  bool stopping_ = false;
  std::thread thread_;
  std::shared_ptr<Session> session_;

  // The bridge's thread only: joining the DDS link until it is joined.
  LinkRetry link_retry_;

  // Set by DDS threads when the other spaces' catalog changed; the bridge's thread reads it.
  std::atomic<bool> remote_pending_{false};
};

}  // namespace urs::bridge
