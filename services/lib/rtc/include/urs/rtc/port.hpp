#pragma once
// RTC::PortService as OpenRTM-aist's ports behave on the wire. One algorithm connects every kind
// of port:
//   connect(cp)          on any port of the connection: gives cp an id if it has none, then asks
//                        cp.ports[0]->notify_connect(cp).
//   notify_connect(cp)   each port in turn: publish its interfaces into cp.properties, ask the
//                        next port in cp.ports, then subscribe what the others published (so what
//                        an earlier port publishes reaches later ones and vice versa), and keep cp.
//   disconnect(id)       asks the first port that answers to notify_disconnect(id), which
//                        unsubscribes and passes it on along cp.ports.
// Connections whose peer ports no longer exist are dropped whenever the profile is read; each
// peer is asked with a 500 ms bound, and one that does not answer in time (paused, busy) is kept
// and not asked again for 10 s, so reading a profile never fails nor waits long because of a peer.
// A connection to a port this port is already connected to is refused (PRECONDITION_NOT_MET)
// unless the profile says dataport.allow_dup_connection=YES, whatever the kind of port, as in
// OpenRTM-aist 2.x: so a peer that forgot its half of a connection cannot connect again until the
// other half is dropped too (notify_disconnect on this port).
// Subclasses (service ports, data ports) supply publish/subscribe/unsubscribe.

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "RTC.hh"

namespace urs::rtc {

class Orb;

class PortBase : public virtual POA_RTC::PortService {
 public:
  // `name` is the port's own name ("diagnostic"); its full name becomes "<instance>.<name>"
  // when its component adds it. `port_type` is "CorbaPort", "DataInPort" or "DataOutPort".
  PortBase(std::string name, std::string port_type);
  ~PortBase() override;
  PortBase(const PortBase&) = delete;
  PortBase& operator=(const PortBase&) = delete;

  const std::string& short_name() const { return short_name_; }
  std::string name() const;                // "<instance>.<name>" once added, else the short name
  std::string instance_name() const;       // the owning component's instance name ("" before)
  RTC::PortService_ptr reference() const;  // nil before the port is attached; caller owns

  // ---- RTC::PortService ----
  RTC::PortProfile* get_port_profile() override;
  RTC::ConnectorProfileList* get_connector_profiles() override;
  RTC::ConnectorProfile* get_connector_profile(const char* connector_id) override;
  RTC::ReturnCode_t connect(RTC::ConnectorProfile& connector_profile) override;
  RTC::ReturnCode_t disconnect(const char* connector_id) override;
  RTC::ReturnCode_t disconnect_all() override;
  RTC::ReturnCode_t notify_connect(RTC::ConnectorProfile& connector_profile) override;
  RTC::ReturnCode_t notify_disconnect(const char* connector_id) override;

  // Called by the owning component (Component::add_port / its destruction).
  void attach(Orb& orb, const std::string& instance_name, RTC::RTObject_ptr owner);
  void detach();  // disconnects everything, deactivates the servant

  // Removes a connection locally (unsubscribing it) without telling its peers; used when a peer
  // is known to be dead. False if there is no such connection.
  bool drop_connection(const std::string& connector_id);
  // Drops every connection one of whose other ports no longer exists (Liveness::kGone, asked
  // with a 500 ms bound each); returns how many.
  int drop_dead_connections();

  std::size_t connection_count() const;
  // The connections this port holds, as they are (no peer is asked whether it still exists).
  std::vector<RTC::ConnectorProfile> connections() const;

  // What OpenRTM-aist's PortAdmin does on a component's activation and deactivation: the objects
  // the port provides become reachable, or stop being so (Component::serve_while_inactive).
  // Default: nothing. Idempotent.
  virtual void activate_interfaces() {}
  virtual void deactivate_interfaces() {}

 protected:
  // Writes what this port offers into profile.properties (service port: its providers' IORs;
  // InPort: its InPortCdr reference). Non-RTC_OK aborts the connection.
  virtual RTC::ReturnCode_t publish_interfaces(RTC::ConnectorProfile& profile) = 0;
  // Takes what this port needs from profile.properties (consumer: a provider IOR; OutPort: the
  // peer's InPortCdr). Non-RTC_OK aborts the connection.
  virtual RTC::ReturnCode_t subscribe_interfaces(const RTC::ConnectorProfile& profile) = 0;
  virtual void unsubscribe_interfaces(const RTC::ConnectorProfile& profile) = 0;

  // Called at the end of attach() and at the start of detach(): a subclass activates and
  // deactivates the CORBA objects it offers (providers, InPortCdr) here.
  virtual void attached() {}
  virtual void detaching() {}
  Orb& orb() const { return *orb_; }  // valid once attached

  // Describes the port in its profile; call from the subclass constructor.
  void add_interface(const std::string& instance_name, const std::string& type_name,
                     RTC::PortInterfacePolarity polarity);
  void set_property(const std::string& name, const std::string& value);

  // This port's position in profile.ports (compared by equivalent reference); -1 if absent.
  int index_in(const RTC::ConnectorProfile& profile) const;

 private:
  void erase_connection(const std::string& connector_id);  // unsubscribes and forgets it
  // Tells profile.ports[next] (and so the ports after it) to forget a connection that failed.
  void forget_after(const RTC::ConnectorProfile& profile, CORBA::ULong next);
  // Whether a peer port is gone (Liveness::kGone); a quiet peer counts as there.
  bool peer_gone(Orb& orb, RTC::PortService_ptr peer);
  // As OpenRTM-aist's ports (of every kind) do in notify_connect: true if this port already holds a
  // connection listing one of the other ports of `profile` (dataport.allow_dup_connection=YES in
  // the profile lets it pass). With the mutex held.
  bool already_connected_to(const RTC::ConnectorProfile& profile) const;

  const std::string short_name_;
  mutable std::mutex mutex_;
  Orb* orb_ = nullptr;
  std::string instance_name_;
  RTC::PortService_var self_;
  RTC::RTObject_var owner_;
  RTC::PortInterfaceProfileList interfaces_;
  SDOPackage::NVList properties_;
  std::vector<RTC::ConnectorProfile> connections_;
  std::map<std::string, std::chrono::steady_clock::time_point> quiet_peers_;  // IOR -> ask again after
};

// A fresh connector id (a random UUID, as OpenRTM-aist assigns).
std::string make_uuid();

}  // namespace urs::rtc
