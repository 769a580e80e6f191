#pragma once
// The bridge RTC's service port towards RT providers. Unlike an ordinary consumer port, which
// holds one provider per required interface, it takes part in any number of connections and
// records, for each, every provider interface the other ports published (OpenRTM-aist's
// "<instance>.port.<port>.provided.<type>.<name>" keys, or the old "port.<type>.<name>" ones).
// Whoever connects a provider to it (the bridge's own discovery, `urs rtc con`, rtcon) makes that
// provider a CAMUS service; disconnecting withdraws it.

#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "urs/rtc/port.hpp"

namespace urs::rt_call {

struct ProvidedInterface {
  std::string key;            // the connector property it was published under
  std::string component;      // the providing component's instance name ("" for an old-style key)
  std::string port;           // the providing port's name ("" for an old-style key)
  std::string type_name;      // e.g. "URC::Navigation"
  std::string instance_name;  // the interface instance name
  std::string ior;
};

// Reads the provided interfaces published in a connector's properties (each IOR once).
std::vector<ProvidedInterface> provided_interfaces(const SDOPackage::NVList& properties);

// What a service port provides, got as a foreign consumer gets it: a connection holding only that
// port (which publishes its interfaces), removed again at once. Empty if the port refuses the
// connection. CORBA system exceptions propagate.
std::vector<ProvidedInterface> offered_by(RTC::PortService_ptr port);

// The type ID inside a stringified IOR ("IOR:..."), "" if the text is not one.
std::string ior_type_id(const std::string& ior);

// A service port towards any number of RT providers (the bridge RTC's "providers").
class ProviderPort : public rtc::PortBase {
 public:
  explicit ProviderPort(std::string name);
  ~ProviderPort() override;

  // Connector id -> the interfaces the other ports of that connection provide.
  std::map<std::string, std::vector<ProvidedInterface>> connections() const;

 protected:
  RTC::ReturnCode_t publish_interfaces(RTC::ConnectorProfile& profile) override;
  RTC::ReturnCode_t subscribe_interfaces(const RTC::ConnectorProfile& profile) override;
  void unsubscribe_interfaces(const RTC::ConnectorProfile& profile) override;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, std::vector<ProvidedInterface>> connections_;
};

}  // namespace urs::rt_call
