#pragma once
// A service port (port.port_type=CorbaPort) with OpenRTM-aist's connection conventions:
// - a provider publishes its object's IOR (a string Any) under both
//     <instance>.port.<port>.provided.<type_name>.<instance_name>   and   port.<type_name>.<instance_name>
// - a consumer takes the value of <instance>.port.<port>.required.<type_name>.<instance_name>
//   (the name of a provider key), else the old-style port.<type_name>.<instance_name>; values
//   "nil"/"null" and anything not starting with "IOR:" are ignored. With
//   port.connection.strictness=strict a consumer left without a provider fails the connection.

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "urs/rtc/port.hpp"

namespace urs::rtc {

// The provider a consumer is connected to: nil until a connection supplies one, nil again after
// it is disconnected. Thread-safe.
class Consumer {
 public:
  Consumer(std::string instance_name, std::string type_name)
      : instance_name_(std::move(instance_name)), type_name_(std::move(type_name)) {}

  const std::string& instance_name() const { return instance_name_; }
  const std::string& type_name() const { return type_name_; }

  CORBA::Object_ptr object() const;  // caller owns; nil if not connected
  bool connected() const;
  // The provider narrowed to the IDL interface T (e.g. URS::Diagnostic); nil if not connected.
  template <typename T>
  typename T::_var_type get() const {
    CORBA::Object_var object = this->object();
    return CORBA::is_nil(object) ? T::_nil() : T::_narrow(object);
  }

  void set(CORBA::Object_ptr object, const std::string& connector_id);
  void clear(const std::string& connector_id);  // only if `connector_id` supplied the current one

 private:
  const std::string instance_name_;
  const std::string type_name_;
  mutable std::mutex mutex_;
  CORBA::Object_var object_;
  std::string connector_id_;
};

class CorbaPort : public PortBase {
 public:
  explicit CorbaPort(std::string name);
  ~CorbaPort() override;

  // Offers `servant` (activated by the port when it is attached) as interface `type_name` (the
  // IDL scoped name, e.g. "URS::Diagnostic") named `instance_name`. Call before the component
  // adds the port. The servant must outlive the port.
  void provide(const std::string& instance_name, const std::string& type_name, PortableServer::ServantBase& servant);
  // Declares a required interface; the returned consumer lives as long as the port.
  Consumer& require(const std::string& instance_name, const std::string& type_name);

  // The provided objects keep their IORs across these (each is reactivated under its first id).
  void activate_interfaces() override;
  void deactivate_interfaces() override;

 protected:
  void attached() override;
  void detaching() override;
  RTC::ReturnCode_t publish_interfaces(RTC::ConnectorProfile& profile) override;
  RTC::ReturnCode_t subscribe_interfaces(const RTC::ConnectorProfile& profile) override;
  void unsubscribe_interfaces(const RTC::ConnectorProfile& profile) override;

 private:
  struct Provider {
    std::string instance_name;
    std::string type_name;
    PortableServer::ServantBase* servant;
    std::string ior;                    // set when first published
    PortableServer::ObjectId_var id{};  // its object id in the POA, kept while inactive
    bool active = false;
  };
  std::string provided_key(const Provider& provider) const;
  std::string required_key(const Consumer& consumer) const;

  std::mutex mutex_;
  std::vector<Provider> providers_;
  std::vector<std::unique_ptr<Consumer>> consumers_;
  bool attached_ = false;  // providers are active
};

}  // namespace urs::rtc
