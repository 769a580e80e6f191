#include "rtc_conf.hpp"

#include <iostream>

#include "urs/rtc/nvlist.hpp"

namespace urs::cli::rtc_cli {
namespace {

// Runs calls on the component's Configuration, turning its refusals (user exceptions carrying a
// description) into failures that name the component.
template <class Body>
auto configuring(const std::string& path, Body&& body) -> decltype(body()) {
  try {
    return calling(path, body);
  } catch (const SDOPackage::InvalidParameter& e) {
    throw Failure(kFailed, path + ": " + e.description.in());
  } catch (const SDOPackage::NotAvailable& e) {
    throw Failure(kFailed, path + ": " + e.description.in());
  } catch (const SDOPackage::InternalError& e) {
    throw Failure(kFailed, path + ": internal error: " + e.description.in());
  } catch (const SDOPackage::InterfaceNotImplemented& e) {
    throw Failure(kFailed, path + ": has no configuration (" + std::string(e.description.in()) + ")");
  }
}

SDOPackage::Configuration_ptr configuration_of(Session& session, const std::string& path) {
  RTC::RTObject_var target = session.component(path);
  SDOPackage::Configuration_var configuration = configuring(path, [&] { return target->get_configuration(); });
  if (CORBA::is_nil(configuration)) throw Failure(kFailed, path + ": has no configuration");
  return configuration._retn();
}

SDOPackage::ConfigurationSet* set_named(SDOPackage::Configuration_ptr configuration, const std::string& path,
                                        const std::string& id) {
  return configuring(path, [&] {
    return id.empty() ? configuration->get_active_configuration_set()
                      : configuration->get_configuration_set(id.c_str());
  });
}

// The value of `name` in `set`, or a failure listing the set's parameters.
std::string value_in(const SDOPackage::ConfigurationSet& set, const std::string& path, const std::string& name) {
  std::string names;
  for (CORBA::ULong i = 0; i < set.configuration_data.length(); ++i) {
    if (name == set.configuration_data[i].name.in()) return rtc::any_to_text(set.configuration_data[i].value);
    names += (names.empty() ? "" : ", ") + std::string(set.configuration_data[i].name.in());
  }
  throw Failure(kFailed, path + ": configuration set " + set.id.in() + " has no parameter '" + name +
                             "' (parameters: " + (names.empty() ? "none" : names) + ")");
}

}  // namespace

int conf_list(Session& session, const std::string& path) {
  SDOPackage::Configuration_var configuration = configuration_of(session, path);
  SDOPackage::ConfigurationSetList_var sets =
      configuring(path, [&] { return configuration->get_configuration_sets(); });
  std::string active;
  try {
    SDOPackage::ConfigurationSet_var set =
        configuring(path, [&] { return configuration->get_active_configuration_set(); });
    active = set->id.in();
  } catch (const Failure&) {
    // No active set (NotAvailable): none is marked.
  }
  for (CORBA::ULong i = 0; i < sets->length(); ++i) {
    const SDOPackage::ConfigurationSet& set = sets[i];
    std::cout << set.id.in() << (active == set.id.in() ? " (active)" : "");
    if (*set.description.in() != '\0') std::cout << "  " << set.description.in();
    std::cout << "\n";
    for (const std::string& line : rtc::nv_lines(set.configuration_data)) std::cout << "  " << line << "\n";
  }
  return kOk;
}

int conf_get(Session& session, const std::string& path, const std::string& name, const std::string& set) {
  SDOPackage::Configuration_var configuration = configuration_of(session, path);
  SDOPackage::ConfigurationSet_var found = set_named(configuration, path, set);
  std::cout << value_in(found.in(), path, name) << "\n";
  return kOk;
}

int conf_set(Session& session, const std::string& path, const std::string& name, const std::string& value,
             const std::string& set) {
  SDOPackage::Configuration_var configuration = configuration_of(session, path);
  SDOPackage::ConfigurationSet_var current = set_named(configuration, path, set);
  value_in(current.in(), path, name);  // the parameter exists
  SDOPackage::ConfigurationSet_var active =
      configuring(path, [&] { return configuration->get_active_configuration_set(); });
  const std::string id = current->id.in();
  SDOPackage::ConfigurationSet change;
  change.id = current->id;
  change.description = current->description;
  rtc::nv_set(change.configuration_data, name, value);
  const bool accepted = configuring(path, [&] { return configuration->set_configuration_set_values(change); });
  if (!accepted) throw Failure(kFailed, path + ": configuration set " + id + " refused " + name + "=" + value);
  if (id == active->id.in()) configuring(path, [&] { return configuration->activate_configuration_set(id.c_str()); });
  // A component may take the call and keep another value (one its parameter's type cannot
  // hold, or an on-update callback's refusal) without saying so: the set read back tells.
  SDOPackage::ConfigurationSet_var after = set_named(configuration, path, id);
  const std::string kept = value_in(after.in(), path, name);
  if (kept != value) {
    throw Failure(kFailed, path + ": parameter '" + name + "' was set to '" + value + "' but the component keeps '" +
                               kept + "': it refused the value");
  }
  return kOk;
}

int conf_activate(Session& session, const std::string& path, const std::string& set) {
  SDOPackage::Configuration_var configuration = configuration_of(session, path);
  const bool done = configuring(path, [&] { return configuration->activate_configuration_set(set.c_str()); });
  if (!done) throw Failure(kFailed, path + ": configuration set " + set + " was not activated");
  return kOk;
}

}  // namespace urs::cli::rtc_cli
