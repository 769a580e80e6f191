#pragma once
// The bridge (the papers' RSCM / SAM-RTC): one RT-Component and one Planet session that make the
// services of each world usable from the other, generically, from interface descriptions alone.
//
//   RT provider -> CAMUS   every provider port connected to the bridge RTC's "providers" port
//                          becomes a CAMUS service whose calls go to the provider by DII
//                          (corba_agent::CorbaProxyAgent, hosted on the bridge's Planet session).
//   CAMUS SA -> RT         every selected CAMUS service becomes an RT-Component in the naming
//                          service with a provider port of its interface (AgentComponent hosting
//                          a CamusForwardingAgent).
//   data                   RT OutPorts feed CAMUS events (and context); CAMUS events feed RT InPorts.
//
// The bridge RTC's lifecycle drives it: activating it opens the Planet session, registers the
// proxies and creates the wrapper RTCs; deactivating it withdraws them all. While active it polls
// the naming service (connector role: providers matching the rules are connected to the bridge,
// and their proxies withdrawn when they vanish or are gone, kept and marked when merely slow;
// every connection it drops is dropped on both ends) and the CAMUS registry. With a data dir it
// keeps the connections of its RTCs and makes them again after a restart (ConnectionStore).
//
// Loops are prevented by origin: what the bridge offers carries "urslink.origin" (a CAMUS property
// "rtc:<path>:<port>", a component property "camus:<service>"), and nothing that carries one is
// bridged again.

#include <atomic>
#include <condition_variable>
#include <memory>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "urs/bridge/config.hpp"
#include "urs/bridge/connection_store.hpp"
#include "urs/bridge/dds_link.hpp"
#include "urs/bridge/interfaces.hpp"
#include "urs/planet/client.hpp"
#include "urs/rtc/manager.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/port.hpp"

namespace urs::bridge {

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
  class Component;
  class Session;
  struct Known;  // a component found in the naming service

  void request_active(bool active);  // from the RTC's lifecycle hooks
  void run();
  void open_session();
  void open_planet(Session& session);
  void close_session();
  void poll_rt();
  void share_rtc_states();
  void poll_camus();
  void reconcile_exports();
  // The bridge RTC's port of a link key ("<port>": providers; "<port>#<ours>": that data port).
  rtc::PortBase& our_port(const std::string& link);
  // Drops one connection the bridge made, on both ends: notify_disconnect on the peer's port
  // (best effort, bounded), then our port's half.
  void drop_link(const Known& known, const std::string& link, const std::string& connector_id);
  // Drops, on `peer`, the connections listing `ours` that `ours` no longer holds; returns how many.
  int drop_stale_halves(const std::string& path, RTC::PortService_ptr peer, const std::string& peer_name,
                        rtc::PortBase& ours);
  // urslink.health and rtc.state of an RT provider, from what the last poll saw of its component.
  void add_health(std::map<std::string, std::string>& properties, const Known& known) const;
  // Registers again every RT provider whose health changed since it was last registered.
  void update_health(Session& session);
  // For CorbaProxyOptions::explain_missing_target: the state of the component at `path` (IOR
  // `ior`) when it is why its provider does not exist; empty if not.
  std::function<std::string()> owner_state_check(const std::string& path, const std::string& ior) const;

  // Restarts (ConnectionStore): at a session's opening, what was saved becomes connections to
  // restore (and, in a new process, the peers first drop their stale halves); each RT poll
  // restores those whose RTC is back and saves what the bridge's RTCs hold.
  void load_connections();
  void restore_connections(Session& session);
  void save_connections(Session& session);
  // The RTC of the bridge for a SavedConnection::rtc key; nullptr if it is not there (now).
  rtc::Component* our_rtc(Session& session, const std::string& key) const;
  void on_data(std::size_t entry, const google::protobuf::Message& value);
  void poll_dds();
  void sync_dds_exports(Session& session);
  void serve_remote(Session& session, call::Request request, call::Responder responder);
  void import_remote(Session& session, const ServiceEntry& entry);
  void withdraw_remote(Session& session, const std::string& key);

  rtc::Orb& orb_;
  rtc::NamingClient* naming_;
  rtc::Manager* manager_;
  const InterfaceCatalog& catalog_;
  const BridgeConfig config_;
  std::optional<planet::ClientOptions> planet_;
  std::string own_path_;

  Component* component_ = nullptr;

  mutable std::mutex mutex_;  // guards the fields below and session_ swaps
  std::condition_variable wake_;
  bool want_active_ = false;
  bool stopping_ = false;
  std::thread thread_;
  std::shared_ptr<Session> session_;

  // Set by DDS threads when the other spaces' catalog changed; the bridge's thread reads it.
  std::atomic<bool> remote_pending_{false};

  // Used by the bridge's thread only.
  std::map<std::string, std::shared_ptr<Known>> known_;  // by naming path
  std::set<std::string> warned_;                         // problems logged once
  ConnectionStore store_;
  bool stale_halves_dropped_ = false;  // once per process, at its first session
  struct Restore {
    SavedConnection saved;
    std::chrono::steady_clock::time_point retry_at;
  };
  std::vector<Restore> restores_;  // saved connections not made again yet
};

}  // namespace urs::bridge
