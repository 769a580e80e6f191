#include "urs/rtc/configuration.hpp"

#include "urs/rtc/nvlist.hpp"

namespace urs::rtc {

void ComponentConfiguration::declare(const std::string& name, const std::string& value) {
  std::lock_guard lock(mutex_);
  for (auto& [key, current] : parameters_) {
    if (key == name) {
      current = value;
      return;
    }
  }
  parameters_.emplace_back(name, value);
}

SDOPackage::ConfigurationSet ComponentConfiguration::default_set() const {
  SDOPackage::ConfigurationSet set;
  set.id = CORBA::string_dup(kSetId);
  set.description = CORBA::string_dup("the component's parameters (read-only)");
  for (const auto& [name, value] : parameters_) nv_set(set.configuration_data, name, value);
  return set;
}

SDOPackage::ParameterList* ComponentConfiguration::get_configuration_parameters() {
  // Parameter carries a TypeCode and allowed values that no URSLink component constrains.
  return new SDOPackage::ParameterList;
}

SDOPackage::NVList* ComponentConfiguration::get_configuration_parameter_values() {
  std::lock_guard lock(mutex_);
  return new SDOPackage::NVList(default_set().configuration_data);
}

CORBA::Any* ComponentConfiguration::get_configuration_parameter_value(const char* name) {
  std::lock_guard lock(mutex_);
  for (const auto& [key, value] : parameters_) {
    if (key == name) {
      auto* any = new CORBA::Any;
      *any <<= value.c_str();
      return any;
    }
  }
  throw SDOPackage::InvalidParameter((std::string("no configuration parameter ") + name).c_str());
}

SDOPackage::ConfigurationSetList* ComponentConfiguration::get_configuration_sets() {
  std::lock_guard lock(mutex_);
  auto* sets = new SDOPackage::ConfigurationSetList;
  sets->length(1);
  (*sets)[0] = default_set();
  return sets;
}

SDOPackage::ConfigurationSet* ComponentConfiguration::get_configuration_set(const char* config_id) {
  if (std::string(config_id) != kSetId) {
    // The operation declares no InvalidParameter: an unknown id is reported as NotAvailable.
    throw SDOPackage::NotAvailable((std::string("no configuration set ") + config_id).c_str());
  }
  std::lock_guard lock(mutex_);
  return new SDOPackage::ConfigurationSet(default_set());
}

SDOPackage::ConfigurationSet* ComponentConfiguration::get_active_configuration_set() {
  std::lock_guard lock(mutex_);
  return new SDOPackage::ConfigurationSet(default_set());
}

CORBA::Boolean ComponentConfiguration::activate_configuration_set(const char* config_id) {
  if (std::string(config_id) == kSetId) return true;  // already the active one
  throw SDOPackage::InvalidParameter((std::string("no configuration set ") + config_id).c_str());
}

}  // namespace urs::rtc
