#pragma once
// SDOPackage::Configuration as OpenRTM-aist's tools use it (rtshell's rtconf and rtcat, the RT
// System Editor): named configuration sets, one of them active, each holding a value (text) for
// every parameter the component declares. Changing a value of the active set, or activating
// another set, tells the component at once: each changed parameter's `apply` runs before the
// call returns, so `rtconf set` takes effect in the component's behaviour.
//
// Refusals are InvalidParameter exceptions whose description says what and why (rtctree ignores
// the boolean results, so an exception is the only refusal a tool reports):
//   - an unknown parameter, set id or empty id; a value that is not a string, number or boolean;
//   - a value the parameter's `check` refuses ("radius: 'abc' is not a number");
//   - a change of a read-only parameter (declared without `apply`);
//   - adding a set whose id exists, removing "default" or the active set.
// A parameter may instead take every value and decline, when applying it, one it cannot use
// (its `apply` throws ValueNotTaken): OpenRTM-aist's way, whose configuration never refuses a
// value. The call succeeds, the parameter keeps the value in effect and the set shows that value
// again, so a tool that reads the set back sees what the component kept (`urs rtc conf set` does).
// Values travel as string Anys (numbers and booleans are accepted and kept as their text).
// get_configuration_parameters() returns an empty list: no URSLink parameter carries the SDO
// TypeCode / allowed-values description (rtctree and OpenRTM-aist's tools do not read it).
//
// Threading: every operation may come from any ORB thread; they are serialised. `check` and
// `apply` run in the calling thread with that serialisation held: they must not call back into
// the configuration, and `apply` must be safe against the component's own threads.

#include <functional>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "SDOPackage.hh"

namespace urs::rtc {

struct ParameterSpec {
  std::string name;
  std::string value;  // its value in "default" when declared
  // "" if `value` is acceptable, else why not (without the parameter's name). Empty: any text.
  std::function<std::string(const std::string& value)> check;
  // Makes an accepted value take effect; runs whenever the active set's value changes. Empty:
  // the parameter is read-only (shown, and a different value is refused). May throw
  // ValueNotTaken to keep the value in effect instead (see above).
  std::function<void(const std::string& value)> apply;
};

// Thrown by a ParameterSpec::apply that does not take a value (what() says why): the parameter
// keeps the value in effect, which its set shows again; the tool's call still succeeds.
struct ValueNotTaken : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A ParameterSpec::check for a finite decimal number within [min, max] (urs/util/number.hpp).
std::function<std::string(const std::string&)> number_between(double min, double max);

class ComponentConfiguration : public virtual POA_SDOPackage::Configuration {
 public:
  static constexpr const char* kDefaultSet = "default";

  ComponentConfiguration();

  // The component's instance name, for log lines; set once by the component before it serves.
  void set_owner(const std::string& instance_name);

  // Adds a parameter (or replaces one of that name) with `spec.value` in every set; the value in
  // effect is `spec.value` (apply is not called for it). Throws std::invalid_argument for an
  // empty name or a value `check` refuses.
  void declare(ParameterSpec spec);
  // The value of `name` in the active set; nullopt if there is no such parameter.
  std::optional<std::string> active_value(const std::string& name) const;

  // ---- SDOPackage::Configuration ----
  CORBA::Boolean set_device_profile(const SDOPackage::DeviceProfile&) override { return false; }
  CORBA::Boolean add_service_profile(const SDOPackage::ServiceProfile&) override { return false; }
  CORBA::Boolean add_organization(SDOPackage::Organization_ptr) override { return false; }
  CORBA::Boolean remove_service_profile(const char*) override { return false; }
  CORBA::Boolean remove_organization(const char*) override { return false; }
  SDOPackage::ParameterList* get_configuration_parameters() override;
  SDOPackage::NVList* get_configuration_parameter_values() override;
  CORBA::Any* get_configuration_parameter_value(const char* name) override;
  CORBA::Boolean set_configuration_parameter(const char* name, const CORBA::Any& value) override;
  SDOPackage::ConfigurationSetList* get_configuration_sets() override;
  SDOPackage::ConfigurationSet* get_configuration_set(const char* config_id) override;
  CORBA::Boolean set_configuration_set_values(const SDOPackage::ConfigurationSet& configuration_set) override;
  SDOPackage::ConfigurationSet* get_active_configuration_set() override;
  CORBA::Boolean add_configuration_set(const SDOPackage::ConfigurationSet& configuration_set) override;
  CORBA::Boolean remove_configuration_set(const char* config_id) override;
  CORBA::Boolean activate_configuration_set(const char* config_id) override;

 private:
  struct Set {
    std::string id;
    std::string description;
    std::vector<std::pair<std::string, std::string>> values;  // one per declared parameter, in declaration order
  };
  using Values = std::vector<std::pair<std::string, std::string>>;

  // All with the lock held.
  Set* find_set(const std::string& id);
  const ParameterSpec* find_parameter(const std::string& name) const;
  // `base` with `changes` applied, each checked; throws InvalidParameter naming the first refusal.
  Values merged(const Values& base, const SDOPackage::NVList& changes, const std::string& set_id) const;
  Values merged(const Values& base, const Values& changes, const std::string& set_id) const;
  // Runs `apply` of each parameter whose value in `values` differs from the one in effect; a
  // value not taken (ValueNotTaken) is replaced in `values` by the one in effect.
  void take_effect(Values& values);
  SDOPackage::ConfigurationSet to_idl(const Set& set) const;

  mutable std::mutex mutex_;
  std::string owner_;
  std::vector<ParameterSpec> parameters_;
  std::vector<Set> sets_;  // "default" first
  std::string active_;     // id of the active set
  Values in_effect_;       // per parameter, the value last applied
};

}  // namespace urs::rtc
