#pragma once
// SDOPackage::Configuration as a component offers it to tools (rtshell's rtconf and rtcat, the
// RT System Editor): one configuration set, "default", active, holding the parameters the
// component declares, as strings. The set is read-only from outside: the operations that would
// change it, or add profiles and organizations, answer false.

#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "SDOPackage.hh"

namespace urs::rtc {

class ComponentConfiguration : public virtual POA_SDOPackage::Configuration {
 public:
  static constexpr const char* kSetId = "default";

  void declare(const std::string& name, const std::string& value);  // adds or replaces

  CORBA::Boolean set_device_profile(const SDOPackage::DeviceProfile&) override { return false; }
  CORBA::Boolean add_service_profile(const SDOPackage::ServiceProfile&) override { return false; }
  CORBA::Boolean add_organization(SDOPackage::Organization_ptr) override { return false; }
  CORBA::Boolean remove_service_profile(const char*) override { return false; }
  CORBA::Boolean remove_organization(const char*) override { return false; }
  SDOPackage::ParameterList* get_configuration_parameters() override;
  SDOPackage::NVList* get_configuration_parameter_values() override;
  CORBA::Any* get_configuration_parameter_value(const char* name) override;
  CORBA::Boolean set_configuration_parameter(const char*, const CORBA::Any&) override { return false; }
  SDOPackage::ConfigurationSetList* get_configuration_sets() override;
  SDOPackage::ConfigurationSet* get_configuration_set(const char* config_id) override;
  CORBA::Boolean set_configuration_set_values(const SDOPackage::ConfigurationSet&) override { return false; }
  SDOPackage::ConfigurationSet* get_active_configuration_set() override;
  CORBA::Boolean add_configuration_set(const SDOPackage::ConfigurationSet&) override { return false; }
  CORBA::Boolean remove_configuration_set(const char*) override { return false; }
  CORBA::Boolean activate_configuration_set(const char* config_id) override;

 private:
  SDOPackage::ConfigurationSet default_set() const;  // lock held

  mutable std::mutex mutex_;
  std::vector<std::pair<std::string, std::string>> parameters_;
};

}  // namespace urs::rtc
