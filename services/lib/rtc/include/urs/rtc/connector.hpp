#pragma once
// Keeps service ports connected without a person running a tool: watches the naming service and
// connects each consumer port that requires an interface to a live port providing it, as rules
// say; reconnects when the provider is replaced (restarted and rebound), disconnects when it
// leaves or dies. Foreign (OpenRTM-aist) components take part on equal terms: only standard
// RTObject / PortService calls and the standard connector properties are used.
//
// The naming service sends no notifications, so the connector polls. One poll (steps 1 and 2 are
// the shared naming watch, urs/rtc/naming_watch.hpp; the rest is this connector's strategy):
//   1. lists the whole tree and resolves each watched "*.rtc" binding (a name matching some
//      rule's consumer or provider pattern), comparing stringified IORs with the last poll;
//   2. forgets components whose binding went away or now names another object (a restart),
//      disconnecting the connections it knows of that involve them;
//   3. reads the profile (get_component_profile) of new and changed components only; a binding
//      whose object does not answer is read again after `retry_period`;
//   4. probes (_non_existent, bounded by `probe_timeout`) each provider that a consumer is
//      connected to, once per provider component, and disconnects the consumers of a dead one;
//   5. connects every required interface left without a provider.
// So a provider that appears is connected within one poll period plus the work of one poll.
//
// Choice of provider, for each (consumer port, required interface): the first rule whose
// `interface` equals the interface's type_name and whose `consumers` pattern matches the
// consumer's naming path decides; among ports providing that type_name on components matching
// its `providers` pattern, a provider the consumer is already connected to is kept, otherwise the
// first live one in naming-path / port-name / interface-name order is taken. One connection per
// required interface: connect() on the consumer port with the consumer port first, and the
// connector property "<consumer>.port.<port>.required.<type>.<instance>" naming the chosen
// provider's "<provider>.port.<port>.provided.<type>.<instance>" key, so interface instance names
// need not match.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "RTC.hh"
#include "urs/rtc/connector_options.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/naming_watch.hpp"

namespace urs::rtc {

class Orb;

// One connection the connector keeps (made or adopted).
struct ConnectorLink {
  std::string interface;           // type_name
  std::string consumer;            // naming path of the consumer component
  std::string consumer_port;       // full port name "<instance>.<port>"
  std::string consumer_interface;  // the required interface's instance_name
  std::string provider;            // naming path; "" if the provider is not in the naming service
  std::string provider_port;
  std::string provider_interface;  // the provided interface's instance_name ("" if unknown)
  std::string connector_id;
  bool made = false;  // made by this connector (or one of the same name)
};

struct ConnectorEvent {
  enum class Kind { kConnected, kDisconnected };
  Kind kind;
  ConnectorLink link;
  // kConnected: "connected" or "found connected" (adopted). kDisconnected: "provider unbound",
  // "provider rebound to another object", "provider not answering", the same for "consumer ...",
  // or "connector stopped".
  std::string reason;
};

// What one poll saw and did, for logs, tests and latency measurements.
struct PollReport {
  std::string naming_error;  // non-empty: the naming service could not be read, nothing changed
  std::size_t bindings = 0;  // watched component bindings found
  std::size_t fetched = 0;   // component profiles read
  std::size_t probes = 0;    // liveness probes made
  std::size_t connected = 0;
  std::size_t disconnected = 0;
  std::chrono::microseconds naming_time{0};  // listing and resolving
  std::chrono::microseconds total_time{0};
};

class Connector {
 public:
  // `naming_address` is the naming service's HOST:PORT; the connector uses its own client of it.
  Connector(Orb& orb, const std::string& naming_address, ConnectorOptions options);
  ~Connector();  // stop()
  Connector(const Connector&) = delete;
  Connector& operator=(const Connector&) = delete;

  // Called for every connection made, adopted or removed, on the polling thread (or the caller
  // of poll_once), never under the connector's lock. Set before start().
  void on_event(std::function<void(const ConnectorEvent&)> listener);

  // Polls every poll_period on a thread of its own, starting now, with a fresh view: what was
  // known before is forgotten and existing connections are found again (and adopted).
  void start();
  // Stops the thread (an unfinished poll stops at its next step) and, if disconnect_on_stop,
  // disconnects the connections it made. Idempotent. Not from the listener.
  void stop();
  bool running() const;

  // One poll in the caller's thread; serialised with the polling thread's. Not from the listener.
  PollReport poll_once();

  // The connections kept, by consumer path, port and interface. After stop() it still lists those
  // left in place, until start() begins afresh.
  std::vector<ConnectorLink> links() const;
  const ConnectorOptions& options() const { return options_; }

 private:
  struct Interface {
    std::string instance;
    std::string type;
  };
  struct ServicePort {
    std::string name;
    RTC::PortService_var ref;
    std::vector<Interface> provided;  // sorted by instance name
    std::vector<Interface> required;
    RTC::ConnectorProfileList connectors;  // as read; examined once, for adoption
  };
  struct Component {
    std::string ior;
    std::string instance;
    bool reachable = false;
    std::chrono::steady_clock::time_point retry_at;
    CORBA::Object_var probe;         // own reference to the component, with the probe timeout
    std::vector<ServicePort> ports;  // service ports only, sorted by name
  };
  // (consumer path, consumer port, required type, required instance)
  using Slot = std::tuple<std::string, std::string, std::string, std::string>;
  struct Link {
    ConnectorLink info;
    RTC::PortService_var consumer_port;
    RTC::PortService_var provider_port;
    CORBA::Object_var provider_probe;  // for providers outside the naming service
  };

  enum class End { kConsumer, kProvider };

  void run();
  bool stopping() const { return stop_requested_.load(); }
  bool watched(const std::string& path) const;
  const ConnectorRule* rule_for(const std::string& consumer_path, const std::string& type) const;

  // Steps of a poll, in order (poll_mutex_ held).
  bool read_naming(ComponentBindings& bound, PollReport& report);
  void forget_changed(const ComponentBindings& bound, PollReport& report);
  void read_components(const ComponentBindings& bound, PollReport& report);
  void probe_providers(PollReport& report);
  void connect_missing(PollReport& report);

  Component read_component(CORBA::Object_ptr object, const std::string& ior);
  void adopt_connections(const std::string& path, Component& component, PollReport& report);
  // The known component owning `port`: fills the provider fields of `info` and returns the
  // component's probe (caller owns); nil if the port belongs to none.
  CORBA::Object_ptr locate_provider(RTC::PortService_ptr port, ConnectorLink& info) const;
  void connect_slot(const Slot& slot, const ConnectorRule& rule, const Component& consumer,
                    const ServicePort& consumer_port, const Interface& required, PollReport& report);
  CORBA::Object_ptr make_probe(CORBA::Object_ptr object) const;
  bool probe_gone(CORBA::Object_ptr probe, PollReport& report) const;
  // Takes the component out of the choice until retry_period passes, dropping its links.
  void mark_unreachable(const std::string& path, PollReport& report);
  void drop_links_of(const std::string& path, const std::string& as_provider, const std::string& as_consumer,
                     PollReport& report);
  // Forgets the link and asks its `ask` end to disconnect it (failures are only logged).
  void drop_link(const Slot& slot, End ask, const std::string& reason, PollReport& report);
  void emit(const ConnectorEvent& event);

  Orb& orb_;
  NamingClient naming_;
  const ConnectorOptions options_;
  std::function<void(const ConnectorEvent&)> listener_;

  std::mutex poll_mutex_;                        // one poll at a time; guards components_ and changes to links_
  std::map<std::string, Component> components_;  // by naming path

  mutable std::mutex links_mutex_;  // also held by the poll for changes, so links() reads safely
  std::map<Slot, Link> links_;

  mutable std::mutex thread_mutex_;  // guards thread_; the polling thread waits on wake_ with it
  std::condition_variable wake_;
  std::atomic<bool> stop_requested_{false};
  std::thread thread_;
};

}  // namespace urs::rtc
