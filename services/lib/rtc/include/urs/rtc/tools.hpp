#pragma once
// What a tool does to RT-Components it found in the naming service, URSLink's and OpenRTM-aist's
// alike, using the standard interfaces only: read states, find ports, connect and disconnect
// ports the way OpenRTM-aist's tools do. Shared by `urs rtc` and the connector.

#include <string>
#include <vector>

#include "RTC.hh"

namespace urs::rtc {

const char* return_code_name(RTC::ReturnCode_t code);  // "RTC_OK", "PRECONDITION_NOT_MET", ...
const char* state_name(RTC::LifeCycleState state);     // "Created", "Inactive", "Active", "Error"

// The component's state in its first owned execution context; CREATED if it owns none.
// CORBA system exceptions propagate (an unreachable component is the caller's to report).
RTC::LifeCycleState component_state(RTC::RTObject_ptr rtc);

// The port named `name` ("<instance>.<port>" or just "<port>"); nil if there is none.
RTC::PortService_ptr find_port(RTC::RTObject_ptr rtc, const std::string& name);

// Connector properties for connecting these ports: caller's `extra` first; for each required
// service interface that exactly one provided interface of the same type satisfies, the
// new-style "<inst>.port.<port>.required.<type>.<name>" key naming that provider; for data ports
// (port.port_type DataInPort/DataOutPort) the defaults corba_cdr / push / flush / little endian
// and dataport.data_type from the out port's profile.
SDOPackage::NVList connector_properties(const std::vector<RTC::PortProfile>& ports, const SDOPackage::NVList& extra);

// True if two IDL type names name the same type: each may be a scoped name ("URC::Navigation"),
// a repository ID ("IDL:URC/Navigation:1.0", "IDL:omg.org/RTC/TimedLong:1.0") or a bare name
// ("Navigation", as OpenRTM-aist 1.x writes); the shorter must be the tail of the longer.
bool same_type_name(const std::string& a, const std::string& b);

// Why two ports cannot work together, naming both sides; "" if they can (or if a port's kind is
// unknown, so nothing can be said). Refused: a service port and a data port; two data ports of
// one direction; data ports whose dataport.data_type differ; service ports where no required
// interface of one meets a provided interface of the same type on the other, or where neither
// requires anything. A service port that declares no interface is compatible with any.
std::string connection_mismatch(const RTC::PortProfile& a, const RTC::PortProfile& b);

struct Connection {
  RTC::ReturnCode_t code = RTC::RTC_ERROR;
  RTC::ConnectorProfile profile;  // as returned by connect(): connector_id and published keys
};

// Builds a ConnectorProfile (`name`, `id` — empty lets the port assign a UUID —, the ports,
// connector_properties()) and calls connect() on the first port. CORBA exceptions propagate.
Connection connect_ports(const std::vector<RTC::PortService_ptr>& ports, const std::string& name,
                         const SDOPackage::NVList& extra = {}, const std::string& id = {});

// Disconnects every connector of `a` that also holds `b`; returns how many were disconnected.
int disconnect_ports(RTC::PortService_ptr a, RTC::PortService_ptr b);

}  // namespace urs::rtc
