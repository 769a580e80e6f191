#pragma once
// An RT-Component: the servant of IDL:openrtm.aist.go.jp/OpenRTM/DataFlowComponent:1.0 (RTObject
// + DataFlowComponent + SDO), answering what OpenRTM-aist's tools ask. A component author
// derives from Component, adds ports in handle_initialize() and overrides the handle_* hooks it
// needs; the CORBA on_* operations call them. Each component owns one periodic execution context
// (handle 0); contexts of others it takes part in get handles from 1000.
//
// SDO features URSLink does not offer answer as the specification allows: empty lists for
// organizations, service profiles and status; InvalidParameter for an unknown id or status name;
// InterfaceNotImplemented for get_monitoring. get_configuration gives the component's
// configuration sets (urs/rtc/configuration.hpp): the parameters it declares, which tools may
// change, with the component told of each change through the parameter's `apply`.

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "OpenRTM.hh"
#include "urs/rtc/configuration.hpp"

namespace urs::rtc {

class Orb;
class PortBase;
class PeriodicExecutionContext;

struct ComponentInfo {
  std::string type_name;  // instance names are <type_name><N>
  std::string description;
  std::string version = "1.0.0";
  std::string vendor = "URSLink";
  std::string category;
};

// Lifetime: call exit() before destroying a component that was initialized (the Manager does).
// exit() stops the execution context and disconnects the ports while the derived class and its
// ports still exist; destruction alone cannot, because derived members are gone by then.
class Component : public virtual POA_OpenRTM::DataFlowComponent {
 public:
  explicit Component(ComponentInfo info);
  ~Component() override;
  Component(const Component&) = delete;
  Component& operator=(const Component&) = delete;

  // Activates the servant and its execution context (not yet initialized). Called by the
  // Manager (or a test) before initialize(); `properties` end up in the component profile.
  void setup(Orb& orb, const std::string& instance_name, double rate_hz,
             const std::vector<std::pair<std::string, std::string>>& properties = {});
  // Called once after exit() completes (the manager unbinds the name and drops the component).
  void on_exit(std::function<void()> callback);
  // true (the default): the objects its service ports provide answer whatever its state. false:
  // they exist only while it is Active, as OpenRTM-aist makes them (its CorbaPort deactivates them
  // when created and on_deactivated, activates them on_activated; the IORs stay the same, so a
  // call in between gets OBJECT_NOT_EXIST). Call before initialize().
  void serve_while_inactive(bool serve) { serve_while_inactive_ = serve; }

  const ComponentInfo& info() const { return info_; }
  const std::string& instance_name() const { return instance_name_; }
  RTC::RTObject_ptr reference() const;  // caller owns; nil before setup()
  PeriodicExecutionContext& execution_context() { return *context_; }
  std::vector<PortBase*> ports() const;  // in the order they were added
  bool exited() const;

  // ---- RTC::ComponentAction (called by execution contexts) ----
  RTC::ReturnCode_t on_initialize() override;
  RTC::ReturnCode_t on_finalize() override;
  RTC::ReturnCode_t on_startup(RTC::ExecutionContextHandle_t handle) override;
  RTC::ReturnCode_t on_shutdown(RTC::ExecutionContextHandle_t handle) override;
  RTC::ReturnCode_t on_activated(RTC::ExecutionContextHandle_t handle) override;
  RTC::ReturnCode_t on_deactivated(RTC::ExecutionContextHandle_t handle) override;
  RTC::ReturnCode_t on_aborting(RTC::ExecutionContextHandle_t handle) override;
  RTC::ReturnCode_t on_error(RTC::ExecutionContextHandle_t handle) override;
  RTC::ReturnCode_t on_reset(RTC::ExecutionContextHandle_t handle) override;
  // ---- RTC::DataFlowComponentAction ----
  RTC::ReturnCode_t on_execute(RTC::ExecutionContextHandle_t handle) override;
  RTC::ReturnCode_t on_state_update(RTC::ExecutionContextHandle_t handle) override;
  RTC::ReturnCode_t on_rate_changed(RTC::ExecutionContextHandle_t handle) override;
  // ---- RTC::LightweightRTObject ----
  RTC::ReturnCode_t initialize() override;
  RTC::ReturnCode_t finalize() override;
  CORBA::Boolean is_alive(RTC::ExecutionContext_ptr exec_context) override;
  RTC::ReturnCode_t exit() override;
  RTC::ExecutionContextHandle_t attach_context(RTC::ExecutionContext_ptr exec_context) override;
  RTC::ReturnCode_t detach_context(RTC::ExecutionContextHandle_t handle) override;
  RTC::ExecutionContext_ptr get_context(RTC::ExecutionContextHandle_t handle) override;
  RTC::ExecutionContextList* get_owned_contexts() override;
  RTC::ExecutionContextList* get_participating_contexts() override;
  RTC::ExecutionContextHandle_t get_context_handle(RTC::ExecutionContext_ptr cxt) override;
  // ---- RTC::RTObject ----
  RTC::ComponentProfile* get_component_profile() override;
  RTC::PortServiceList* get_ports() override;
  // ---- SDOPackage::SDO / SDOSystemElement ----
  SDOPackage::OrganizationList* get_owned_organizations() override;
  char* get_sdo_id() override;
  char* get_sdo_type() override;
  SDOPackage::DeviceProfile* get_device_profile() override;
  SDOPackage::ServiceProfileList* get_service_profiles() override;
  SDOPackage::ServiceProfile* get_service_profile(const char* id) override;
  SDOPackage::SDOService_ptr get_sdo_service(const char* id) override;
  SDOPackage::Configuration_ptr get_configuration() override;
  SDOPackage::Monitoring_ptr get_monitoring() override;
  SDOPackage::OrganizationList* get_organizations() override;
  SDOPackage::NVList* get_status_list() override;
  CORBA::Any* get_status(const char* name) override;

 protected:
  // Hooks for component authors; the default does nothing and returns RTC_OK.
  virtual RTC::ReturnCode_t handle_initialize() { return RTC::RTC_OK; }
  virtual RTC::ReturnCode_t handle_finalize() { return RTC::RTC_OK; }
  virtual RTC::ReturnCode_t handle_startup(RTC::ExecutionContextHandle_t) { return RTC::RTC_OK; }
  virtual RTC::ReturnCode_t handle_shutdown(RTC::ExecutionContextHandle_t) { return RTC::RTC_OK; }
  virtual RTC::ReturnCode_t handle_activated(RTC::ExecutionContextHandle_t) { return RTC::RTC_OK; }
  virtual RTC::ReturnCode_t handle_deactivated(RTC::ExecutionContextHandle_t) { return RTC::RTC_OK; }
  virtual RTC::ReturnCode_t handle_aborting(RTC::ExecutionContextHandle_t) { return RTC::RTC_OK; }
  virtual RTC::ReturnCode_t handle_error(RTC::ExecutionContextHandle_t) { return RTC::RTC_OK; }
  virtual RTC::ReturnCode_t handle_reset(RTC::ExecutionContextHandle_t) { return RTC::RTC_OK; }
  virtual RTC::ReturnCode_t handle_execute(RTC::ExecutionContextHandle_t) { return RTC::RTC_OK; }
  virtual RTC::ReturnCode_t handle_state_update(RTC::ExecutionContextHandle_t) { return RTC::RTC_OK; }
  virtual RTC::ReturnCode_t handle_rate_changed(RTC::ExecutionContextHandle_t) { return RTC::RTC_OK; }

  // Registers a port (a member of the derived class) and activates it; from handle_initialize().
  void add_port(PortBase& port);
  Orb& orb() const { return *orb_; }
  // Offers a configuration parameter to tools (see ParameterSpec: with `apply` tools may change
  // it, and the component hears of each change at once, in the ORB thread of the tool's call).
  // Throws std::invalid_argument for an empty name or a value its `check` refuses.
  void declare_parameter(ParameterSpec spec);
  // A read-only parameter: tools see `value`, and changing it is refused.
  void declare_parameter(const std::string& name, const std::string& value);
  // The parameter's value in the active configuration set ("" if there is no such parameter).
  std::string parameter(const std::string& name) const;
  // A property given at setup ("" if absent).
  std::string property(const std::string& name) const;

 private:
  // Runs a hook, turning a C++ exception into RTC_ERROR with a log line naming the hook.
  RTC::ReturnCode_t guarded(const char* hook, const std::function<RTC::ReturnCode_t()>& body);

  const ComponentInfo info_;
  Orb* orb_ = nullptr;
  std::string instance_name_;
  std::vector<std::pair<std::string, std::string>> properties_;
  RTC::RTObject_var self_;
  std::unique_ptr<PeriodicExecutionContext> context_;
  std::unique_ptr<ComponentConfiguration> configuration_;
  SDOPackage::Configuration_var configuration_ref_;

  mutable std::mutex mutex_;
  bool initialized_ = false;
  bool exited_ = false;
  bool serve_while_inactive_ = true;
  std::vector<PortBase*> ports_;
  std::map<RTC::ExecutionContextHandle_t, RTC::ExecutionContext_var> participating_;
  RTC::ExecutionContextHandle_t next_participating_handle_ = 1000;
  std::function<void()> exit_callback_;
};

}  // namespace urs::rtc
