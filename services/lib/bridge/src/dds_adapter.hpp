#pragma once
// DdsAdapter: the bridge's side towards the other spaces (internal; docs/federation.md). One per
// session: the DdsLink (catalog and calls) and the SpaceState shared on it. What it gives the
// core: the other spaces' catalog as offers (key and name "<space>/<service>", fields {space}
// {service}, revision the interface and its description), a forwarding agent for each
// (CamusForwardingAgent over the link), and, as a ServiceOffering, this space's catalog: a route's
// stand-in is an announced entry, whose calls are served by the host of forwarding agents or by
// the CAMUS server.
//
// The offers of this space it is given (Bridge): key and name the service's name here, source
// its origin as announced ("camus" for a CAMUS service agent, served by the CAMUS server; else a
// forwarding agent's urslink.origin, served by the host), property deadline_ms.
//
// Calls from other spaces are judged by `dds.export.callers` (call_authorization.hpp) before
// anything else, refused ones answered PERMISSION_DENIED with the reason, and every one, served
// or refused, recorded in the audit log when `dds.audit` names a file (call_audit.hpp).
//
// Threads: the bridge's thread, but calls from other spaces, which arrive on DDS listener threads
// and are handed to `serve` there (it must not block).

#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "forwarding.hpp"
#include "urs/bridge/config.hpp"
#include "urs/bridge/core/route_reconciler.hpp"
#include "urs/bridge/dds_link.hpp"
#include "urs/bridge/call_audit.hpp"
#include "urs/bridge/camus_forwarding_agent.hpp"
#include "urs/bridge/space_state.hpp"
#include "urs/schema/schema.hpp"

namespace urs::bridge {

class DdsAdapter : public core::ServiceOffering {
 public:
  // What the other spaces learn of a service offered to them.
  struct Description {
    std::string interface_name;
    std::string repository_id;
    std::shared_ptr<const std::string> descriptor_set;
  };
  // The description of a route's service; nullopt if it cannot be had now (tried again).
  using Describe = std::function<std::optional<Description>(const core::Route& route)>;
  // A call from another space to a service this space offers; `on_host`: served by the host of
  // forwarding agents, else by the CAMUS server. Runs on a DDS listener thread: must not block.
  using Serve = std::function<void(call::Request request, bool on_host, call::Responder responder)>;

  // Joins the link (throws std::runtime_error if DDS refuses) and shares the space's state on it
  // (logged, and none shared, if that fails). `client` (null: no CAMUS server) outlives this.
  // Also opens the audit log (throws std::runtime_error if it cannot).
  DdsAdapter(const BridgeConfig& config, planet::Client* client, DdsLink::CatalogHandler catalog_changed,
             Describe describe, Serve serve);
  ~DdsAdapter();  // the state first, then the link: the others drop this space's services at once
  DdsAdapter(const DdsAdapter&) = delete;
  DdsAdapter& operator=(const DdsAdapter&) = delete;

  SpaceState* state() { return state_.get(); }
  // True once a lease after the catalog was last read (it is read when DDS says it changed, and
  // once a lease anyway).
  bool catalog_due(std::chrono::steady_clock::time_point now) const;
  // The other spaces' services now.
  std::vector<core::Offer> offers();
  // The agent forwarding calls to the service of an offer of offers() over the link; throws if
  // its description cannot be used.
  std::shared_ptr<agent::ServiceAgent> forwarder(const core::Route& route);
  // True once a lease: what this space announces is announced again (after a cut, the others
  // relearn it); the caller has the routes offered again (RouteReconciler::target_restarted).
  bool announce_due(std::chrono::steady_clock::time_point now);

  // core::ServiceOffering
  core::OfferOutcome offer(const core::Route& route) override;
  void withdraw(const core::Route& route) override;
  void update(const core::Route& route) override;

 private:
  void serve_call(call::Request request, call::Responder responder);

  const BridgeConfig& config_;
  const Describe describe_;
  const Serve serve_;
  std::chrono::steady_clock::time_point catalog_read_at_;
  std::chrono::steady_clock::time_point announced_at_;
  std::map<std::string, ServiceEntry> catalog_;  // the others' entries last read, by "<space>/<service>"
  struct Forwarding {
    std::string revision;
    std::shared_ptr<CamusForwardingAgent> agent;
  };
  std::map<std::string, Forwarding> forwarding_;  // by "<space>/<service>": one agent for its stand-ins
  std::map<std::string, std::unique_ptr<schema::SchemaPool>> space_pools_;
  std::vector<std::unique_ptr<schema::SchemaPool>> extra_pools_;  // descriptions that clash within a space
  std::mutex served_mutex_;                 // read by DDS threads
  std::map<std::string, bool> served_;      // announced name -> on the host (else the CAMUS server)
  std::shared_ptr<CallAudit> audit_;        // null: no audit log; kept by the responders of calls in flight
  std::unique_ptr<DdsLink> link_;           // near last: destroyed early, so no DDS thread outlives what it uses
  std::unique_ptr<SpaceState> state_;       // on `link_`: destroyed before it
};

}  // namespace urs::bridge
