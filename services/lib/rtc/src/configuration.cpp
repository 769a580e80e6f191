#include "urs/rtc/configuration.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>

#include "urs/rtc/nvlist.hpp"
#include "urs/util/number.hpp"

namespace urs::rtc {
namespace {

[[noreturn]] void refuse(const std::string& why) { throw SDOPackage::InvalidParameter(why.c_str()); }

// The text of a configuration value: strings as they are, numbers and booleans as their text.
std::optional<std::string> value_text(const CORBA::Any& value) {
  CORBA::TypeCode_var type = value.type();
  switch (type->kind()) {
    case CORBA::tk_string:
    case CORBA::tk_short:
    case CORBA::tk_ushort:
    case CORBA::tk_long:
    case CORBA::tk_ulong:
    case CORBA::tk_longlong:
    case CORBA::tk_ulonglong:
    case CORBA::tk_boolean:
      return any_to_text(value);
    case CORBA::tk_double: {
      CORBA::Double d = 0;
      value >>= d;
      return util::format_number(d);
    }
    case CORBA::tk_float: {
      CORBA::Float f = 0;
      value >>= f;
      return util::format_number(f);
    }
    default:
      return std::nullopt;
  }
}

std::string names_of(const std::vector<ParameterSpec>& parameters) {
  std::string names;
  for (const auto& p : parameters) names += (names.empty() ? "" : ", ") + p.name;
  return names.empty() ? "none" : names;
}

std::string value_of(const std::vector<std::pair<std::string, std::string>>& values, const std::string& name) {
  for (const auto& [key, value] : values) {
    if (key == name) return value;
  }
  return {};
}

}  // namespace

std::function<std::string(const std::string&)> number_between(double min, double max) {
  return [min, max](const std::string& text) {
    double ignored = 0;
    return util::read_number(text, min, max, ignored);
  };
}

ComponentConfiguration::ComponentConfiguration() : active_(kDefaultSet) {
  sets_.push_back({kDefaultSet, "the component's parameters", {}});
}

void ComponentConfiguration::set_owner(const std::string& instance_name) {
  std::lock_guard lock(mutex_);
  owner_ = instance_name;
}

void ComponentConfiguration::declare(ParameterSpec spec) {
  if (spec.name.empty()) throw std::invalid_argument("a configuration parameter needs a name");
  if (spec.check) {
    const std::string why = spec.check(spec.value);
    if (!why.empty()) throw std::invalid_argument("configuration parameter " + spec.name + ": " + why);
  }
  std::lock_guard lock(mutex_);
  auto put = [&](Values& values) {
    for (auto& [key, value] : values) {
      if (key == spec.name) {
        value = spec.value;
        return;
      }
    }
    values.emplace_back(spec.name, spec.value);
  };
  for (Set& set : sets_) put(set.values);
  put(in_effect_);
  for (auto& parameter : parameters_) {
    if (parameter.name == spec.name) {
      parameter = std::move(spec);
      return;
    }
  }
  parameters_.push_back(std::move(spec));
}

std::optional<std::string> ComponentConfiguration::active_value(const std::string& name) const {
  std::lock_guard lock(mutex_);
  if (find_parameter(name) == nullptr) return std::nullopt;
  for (const Set& set : sets_) {
    if (set.id == active_) return value_of(set.values, name);
  }
  return std::nullopt;
}

ComponentConfiguration::Set* ComponentConfiguration::find_set(const std::string& id) {
  for (Set& set : sets_) {
    if (set.id == id) return &set;
  }
  return nullptr;
}

const ParameterSpec* ComponentConfiguration::find_parameter(const std::string& name) const {
  for (const auto& parameter : parameters_) {
    if (parameter.name == name) return &parameter;
  }
  return nullptr;
}

ComponentConfiguration::Values ComponentConfiguration::merged(const Values& base, const Values& changes,
                                                              const std::string& set_id) const {
  Values result = base;
  for (const auto& change : changes) {
    const std::string& name = change.first;  // named: a lambda below captures it (no structured binding)
    const std::string& value = change.second;
    const ParameterSpec* parameter = find_parameter(name);
    if (parameter == nullptr) {
      refuse("no configuration parameter '" + name + "' (parameters: " + names_of(parameters_) + ")");
    }
    auto slot = std::find_if(result.begin(), result.end(), [&](const auto& entry) { return entry.first == name; });
    if (slot->second == value) continue;
    if (!parameter->apply) {
      refuse(name + " is read-only (its value stays '" + slot->second + "')");
    }
    if (parameter->check) {
      const std::string why = parameter->check(value);
      if (!why.empty()) refuse(name + ": " + why + " (set " + set_id + " unchanged)");
    }
    slot->second = value;
  }
  return result;
}

ComponentConfiguration::Values ComponentConfiguration::merged(const Values& base, const SDOPackage::NVList& changes,
                                                              const std::string& set_id) const {
  Values given;
  for (CORBA::ULong i = 0; i < changes.length(); ++i) {
    const std::string name = changes[i].name.in();
    const auto text = value_text(changes[i].value);
    if (!text) refuse(name + ": the value must be a string, a number or a boolean");
    given.emplace_back(name, *text);
  }
  return merged(base, given, set_id);
}

void ComponentConfiguration::take_effect(Values& values) {
  for (auto& entry : values) {
    const std::string& name = entry.first;  // named: a lambda below captures it (no structured binding)
    std::string& value = entry.second;
    auto current = std::find_if(in_effect_.begin(), in_effect_.end(), [&](const auto& e) { return e.first == name; });
    if (current == in_effect_.end() || current->second == value) continue;
    const ParameterSpec* parameter = find_parameter(name);
    if (parameter == nullptr || !parameter->apply) continue;
    try {
      parameter->apply(value);
    } catch (const ValueNotTaken& e) {
      spdlog::warn("{}: configuration parameter {}: '{}' not taken ({}); it keeps '{}'", owner_, name, value, e.what(),
                   current->second);
      value = current->second;
      continue;
    } catch (const std::exception& e) {
      // `check` accepted it: a failure here is the component's fault, reported as such.
      spdlog::error("{}: configuration parameter {}: applying '{}' failed: {}", owner_, name, value, e.what());
      throw SDOPackage::InternalError((name + ": applying '" + value + "' failed: " + e.what()).c_str());
    }
    spdlog::info("{}: configuration parameter {} = {}", owner_, name, value);
    current->second = value;
  }
}

SDOPackage::ConfigurationSet ComponentConfiguration::to_idl(const Set& set) const {
  SDOPackage::ConfigurationSet out;
  out.id = CORBA::string_dup(set.id.c_str());
  out.description = CORBA::string_dup(set.description.c_str());
  for (const auto& [name, value] : set.values) nv_set(out.configuration_data, name, value);
  return out;
}

// ---- SDOPackage::Configuration ----

SDOPackage::ParameterList* ComponentConfiguration::get_configuration_parameters() {
  return new SDOPackage::ParameterList;
}

SDOPackage::NVList* ComponentConfiguration::get_configuration_parameter_values() {
  std::lock_guard lock(mutex_);
  return new SDOPackage::NVList(to_idl(*find_set(active_)).configuration_data);
}

CORBA::Any* ComponentConfiguration::get_configuration_parameter_value(const char* name) {
  std::lock_guard lock(mutex_);
  if (find_parameter(name) == nullptr) {
    refuse(std::string("no configuration parameter '") + name + "' (parameters: " + names_of(parameters_) + ")");
  }
  auto* any = new CORBA::Any;
  *any <<= value_of(find_set(active_)->values, name).c_str();
  return any;
}

CORBA::Boolean ComponentConfiguration::set_configuration_parameter(const char* name, const CORBA::Any& value) {
  SDOPackage::NVList change;
  change.length(1);
  change[0].name = CORBA::string_dup(name);
  change[0].value = value;
  std::lock_guard lock(mutex_);
  Set& active = *find_set(active_);
  active.values = merged(active.values, change, active.id);
  take_effect(active.values);
  return true;
}

SDOPackage::ConfigurationSetList* ComponentConfiguration::get_configuration_sets() {
  std::lock_guard lock(mutex_);
  auto* list = new SDOPackage::ConfigurationSetList;
  list->length(static_cast<CORBA::ULong>(sets_.size()));
  for (CORBA::ULong i = 0; i < sets_.size(); ++i) (*list)[i] = to_idl(sets_[i]);
  return list;
}

SDOPackage::ConfigurationSet* ComponentConfiguration::get_configuration_set(const char* config_id) {
  std::lock_guard lock(mutex_);
  const Set* set = find_set(config_id);
  // The operation declares no InvalidParameter: an unknown id is reported as NotAvailable.
  if (set == nullptr) throw SDOPackage::NotAvailable((std::string("no configuration set ") + config_id).c_str());
  return new SDOPackage::ConfigurationSet(to_idl(*set));
}

CORBA::Boolean ComponentConfiguration::set_configuration_set_values(const SDOPackage::ConfigurationSet& given) {
  const std::string id = given.id.in();
  if (id.empty()) refuse("the configuration set has no id");
  std::lock_guard lock(mutex_);
  Set* set = find_set(id);
  if (set == nullptr) refuse("no configuration set '" + id + "' (add it first)");
  set->values = merged(set->values, given.configuration_data, id);
  if (id == active_) take_effect(set->values);
  return true;
}

SDOPackage::ConfigurationSet* ComponentConfiguration::get_active_configuration_set() {
  std::lock_guard lock(mutex_);
  return new SDOPackage::ConfigurationSet(to_idl(*find_set(active_)));
}

CORBA::Boolean ComponentConfiguration::add_configuration_set(const SDOPackage::ConfigurationSet& given) {
  const std::string id = given.id.in();
  if (id.empty()) refuse("the configuration set has no id");
  std::lock_guard lock(mutex_);
  if (find_set(id) != nullptr) refuse("configuration set '" + id + "' already exists");
  // A new set starts from the default set's values: every set holds every parameter.
  Set set{id, given.description.in(), merged(find_set(kDefaultSet)->values, given.configuration_data, id)};
  sets_.push_back(std::move(set));
  spdlog::info("{}: configuration set {} added", owner_, id);
  return true;
}

CORBA::Boolean ComponentConfiguration::remove_configuration_set(const char* config_id) {
  const std::string id = config_id;
  std::lock_guard lock(mutex_);
  if (id == kDefaultSet) refuse("the default configuration set cannot be removed");
  if (id == active_) refuse("configuration set '" + id + "' is active (activate another one first)");
  auto it = std::find_if(sets_.begin(), sets_.end(), [&](const Set& set) { return set.id == id; });
  if (it == sets_.end()) refuse("no configuration set '" + id + "'");
  sets_.erase(it);
  spdlog::info("{}: configuration set {} removed", owner_, id);
  return true;
}

CORBA::Boolean ComponentConfiguration::activate_configuration_set(const char* config_id) {
  std::lock_guard lock(mutex_);
  Set* set = find_set(config_id);
  if (set == nullptr) refuse(std::string("no configuration set '") + config_id + "'");
  take_effect(set->values);
  active_ = set->id;
  return true;
}

}  // namespace urs::rtc
