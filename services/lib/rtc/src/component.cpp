#include "urs/rtc/component.hpp"

#include <spdlog/spdlog.h>

#include "urs/rtc/execution_context.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/port.hpp"

namespace urs::rtc {

Component::Component(ComponentInfo info)
    : info_(std::move(info)), configuration_(std::make_unique<ComponentConfiguration>()) {}

Component::~Component() {
  if (context_) context_->shutdown();
  if (orb_ != nullptr) {
    orb_->deactivate(configuration_.get());
    orb_->deactivate(this);
  }
}

void Component::setup(Orb& orb, const std::string& instance_name, double rate_hz,
                      const std::vector<std::pair<std::string, std::string>>& properties) {
  orb_ = &orb;
  instance_name_ = instance_name;
  properties_ = properties;
  CORBA::Object_var object = orb.activate(this);
  self_ = RTC::RTObject::_narrow(object);
  context_ = std::make_unique<PeriodicExecutionContext>(orb, rate_hz);
  context_->bind_owner(self_.in());
  configuration_->set_owner(instance_name);
  CORBA::Object_var configuration = orb.activate(configuration_.get());
  configuration_ref_ = SDOPackage::Configuration::_narrow(configuration);
}

void Component::declare_parameter(ParameterSpec spec) { configuration_->declare(std::move(spec)); }

void Component::declare_parameter(const std::string& name, const std::string& value) {
  configuration_->declare({name, value, {}, {}});
}

std::string Component::parameter(const std::string& name) const {
  return configuration_->active_value(name).value_or("");
}

void Component::on_exit(std::function<void()> callback) {
  std::lock_guard lock(mutex_);
  exit_callback_ = std::move(callback);
}

RTC::RTObject_ptr Component::reference() const { return RTC::RTObject::_duplicate(self_.in()); }

bool Component::exited() const {
  std::lock_guard lock(mutex_);
  return exited_;
}

std::string Component::property(const std::string& name) const {
  for (const auto& [key, value] : properties_) {
    if (key == name) return value;
  }
  return {};
}

void Component::add_port(PortBase& port) {
  port.attach(*orb_, instance_name_, self_.in());
  if (!serve_while_inactive_) port.deactivate_interfaces();  // added while Inactive
  std::lock_guard lock(mutex_);
  ports_.push_back(&port);
}

std::vector<PortBase*> Component::ports() const {
  std::lock_guard lock(mutex_);
  return ports_;
}

RTC::ReturnCode_t Component::guarded(const char* hook, const std::function<RTC::ReturnCode_t()>& body) {
  try {
    return body();
  } catch (const std::exception& e) {
    spdlog::error("{}: {} failed: {}", instance_name_, hook, e.what());
  } catch (const CORBA::Exception& e) {
    spdlog::error("{}: {} failed: {}", instance_name_, hook, describe(e));
  }
  return RTC::RTC_ERROR;
}

// ---- ComponentAction: each runs the author's hook ----

RTC::ReturnCode_t Component::on_initialize() {
  return guarded("on_initialize", [&] { return handle_initialize(); });
}
RTC::ReturnCode_t Component::on_finalize() {
  return guarded("on_finalize", [&] { return handle_finalize(); });
}
RTC::ReturnCode_t Component::on_startup(RTC::ExecutionContextHandle_t h) {
  return guarded("on_startup", [&] { return handle_startup(h); });
}
RTC::ReturnCode_t Component::on_shutdown(RTC::ExecutionContextHandle_t h) {
  return guarded("on_shutdown", [&] { return handle_shutdown(h); });
}
RTC::ReturnCode_t Component::on_activated(RTC::ExecutionContextHandle_t h) {
  spdlog::debug("{}: activating in context {}", instance_name_, h);
  const RTC::ReturnCode_t result = guarded("on_activated", [&] { return handle_activated(h); });
  if (!serve_while_inactive_) {
    for (PortBase* port : ports()) port->activate_interfaces();
  }
  return result;
}
RTC::ReturnCode_t Component::on_deactivated(RTC::ExecutionContextHandle_t h) {
  spdlog::debug("{}: deactivating in context {}", instance_name_, h);
  if (!serve_while_inactive_) {
    for (PortBase* port : ports()) port->deactivate_interfaces();
  }
  return guarded("on_deactivated", [&] { return handle_deactivated(h); });
}
RTC::ReturnCode_t Component::on_aborting(RTC::ExecutionContextHandle_t h) {
  spdlog::warn("{}: entering the Error state in context {}", instance_name_, h);
  return guarded("on_aborting", [&] { return handle_aborting(h); });
}
RTC::ReturnCode_t Component::on_error(RTC::ExecutionContextHandle_t h) {
  return guarded("on_error", [&] { return handle_error(h); });
}
RTC::ReturnCode_t Component::on_reset(RTC::ExecutionContextHandle_t h) {
  spdlog::info("{}: reset in context {}", instance_name_, h);
  return guarded("on_reset", [&] { return handle_reset(h); });
}
RTC::ReturnCode_t Component::on_execute(RTC::ExecutionContextHandle_t h) {
  return guarded("on_execute", [&] { return handle_execute(h); });
}
RTC::ReturnCode_t Component::on_state_update(RTC::ExecutionContextHandle_t h) {
  return guarded("on_state_update", [&] { return handle_state_update(h); });
}
RTC::ReturnCode_t Component::on_rate_changed(RTC::ExecutionContextHandle_t h) {
  return guarded("on_rate_changed", [&] { return handle_rate_changed(h); });
}

// ---- LightweightRTObject ----

RTC::ReturnCode_t Component::initialize() {
  {
    std::lock_guard lock(mutex_);
    if (initialized_ || exited_ || !context_) return RTC::PRECONDITION_NOT_MET;
  }
  const RTC::ReturnCode_t result = on_initialize();
  if (result != RTC::RTC_OK) {
    spdlog::error("{}: on_initialize returned {}", instance_name_, static_cast<int>(result));
    return result;
  }
  {
    std::lock_guard lock(mutex_);
    initialized_ = true;
  }
  return context_->start();
}

RTC::ReturnCode_t Component::finalize() {
  // Only exit() finalizes: while the component takes part in any context (it always does in its
  // own until exit) the specification requires PRECONDITION_NOT_MET.
  return RTC::PRECONDITION_NOT_MET;
}

RTC::ReturnCode_t Component::exit() {
  std::map<RTC::ExecutionContextHandle_t, RTC::ExecutionContext_var> participating;
  {
    std::lock_guard lock(mutex_);
    if (!initialized_ || exited_) return RTC::PRECONDITION_NOT_MET;
    exited_ = true;
    participating = participating_;
  }
  spdlog::info("{}: exiting", instance_name_);
  for (auto& [handle, context] : participating) {
    try {
      if (context->get_component_state(self_.in()) == RTC::ACTIVE) context->deactivate_component(self_.in());
      context->remove_component(self_.in());
    } catch (const CORBA::SystemException& e) {
      spdlog::debug("{}: leaving context {}: {}", instance_name_, handle, describe(e));
    }
  }
  if (context_->get_component_state(self_.in()) == RTC::ACTIVE) context_->deactivate_component(self_.in());
  if (context_->is_running()) context_->stop();
  on_finalize();
  std::vector<PortBase*> ports;
  std::function<void()> callback;
  {
    std::lock_guard lock(mutex_);
    ports = ports_;
    callback = exit_callback_;
  }
  for (PortBase* port : ports) port->detach();
  context_->shutdown();
  if (callback) callback();
  return RTC::RTC_OK;
}

CORBA::Boolean Component::is_alive(RTC::ExecutionContext_ptr exec_context) {
  if (CORBA::is_nil(exec_context)) return false;
  if (get_context_handle(exec_context) < 0) return false;
  std::lock_guard lock(mutex_);
  return !exited_;
}

RTC::ExecutionContextHandle_t Component::attach_context(RTC::ExecutionContext_ptr exec_context) {
  if (CORBA::is_nil(exec_context)) return -1;
  std::lock_guard lock(mutex_);
  const RTC::ExecutionContextHandle_t handle = next_participating_handle_++;
  participating_[handle] = RTC::ExecutionContext::_duplicate(exec_context);
  return handle;
}

RTC::ReturnCode_t Component::detach_context(RTC::ExecutionContextHandle_t handle) {
  RTC::ExecutionContext_var context;
  {
    std::lock_guard lock(mutex_);
    auto it = participating_.find(handle);
    if (it == participating_.end()) return RTC::BAD_PARAMETER;
    context = it->second;
  }
  try {
    if (context->get_component_state(self_.in()) == RTC::ACTIVE) return RTC::PRECONDITION_NOT_MET;
  } catch (const CORBA::SystemException&) {
    // A context that no longer answers cannot run the component any more.
  }
  std::lock_guard lock(mutex_);
  participating_.erase(handle);
  return RTC::RTC_OK;
}

RTC::ExecutionContext_ptr Component::get_context(RTC::ExecutionContextHandle_t handle) {
  if (handle == 0 && context_) return context_->reference();
  std::lock_guard lock(mutex_);
  auto it = participating_.find(handle);
  return it == participating_.end() ? RTC::ExecutionContext::_nil() : RTC::ExecutionContext::_duplicate(it->second);
}

RTC::ExecutionContextList* Component::get_owned_contexts() {
  auto* list = new RTC::ExecutionContextList;
  if (context_) {
    list->length(1);
    (*list)[0] = context_->reference();
  }
  return list;
}

RTC::ExecutionContextList* Component::get_participating_contexts() {
  std::lock_guard lock(mutex_);
  auto* list = new RTC::ExecutionContextList;
  list->length(static_cast<CORBA::ULong>(participating_.size()));
  CORBA::ULong i = 0;
  for (const auto& [handle, context] : participating_) (*list)[i++] = RTC::ExecutionContext::_duplicate(context);
  return list;
}

RTC::ExecutionContextHandle_t Component::get_context_handle(RTC::ExecutionContext_ptr cxt) {
  if (CORBA::is_nil(cxt)) return -1;
  try {
    if (context_) {
      RTC::ExecutionContextService_var own = context_->reference();
      if (own->_is_equivalent(cxt)) return 0;
    }
    std::lock_guard lock(mutex_);
    for (const auto& [handle, context] : participating_) {
      if (context->_is_equivalent(cxt)) return handle;
    }
  } catch (const CORBA::SystemException&) {
  }
  return -1;
}

// ---- RTObject ----

RTC::ComponentProfile* Component::get_component_profile() {
  auto* profile = new RTC::ComponentProfile;
  profile->instance_name = CORBA::string_dup(instance_name_.c_str());
  profile->type_name = CORBA::string_dup(info_.type_name.c_str());
  profile->description = CORBA::string_dup(info_.description.c_str());
  profile->version = CORBA::string_dup(info_.version.c_str());
  profile->vendor = CORBA::string_dup(info_.vendor.c_str());
  profile->category = CORBA::string_dup(info_.category.c_str());
  std::vector<PortBase*> ports;
  {
    std::lock_guard lock(mutex_);
    ports = ports_;
  }
  profile->port_profiles.length(static_cast<CORBA::ULong>(ports.size()));
  for (CORBA::ULong i = 0; i < ports.size(); ++i) {
    RTC::PortProfile_var port = ports[i]->get_port_profile();
    profile->port_profiles[i] = port.in();
  }
  profile->parent = RTC::RTObject::_nil();
  nv_set(profile->properties, "instance_name", instance_name_);
  nv_set(profile->properties, "type_name", info_.type_name);
  nv_set(profile->properties, "description", info_.description);
  nv_set(profile->properties, "version", info_.version);
  nv_set(profile->properties, "vendor", info_.vendor);
  nv_set(profile->properties, "category", info_.category);
  for (const auto& [name, value] : properties_) nv_set(profile->properties, name, value);
  return profile;
}

RTC::PortServiceList* Component::get_ports() {
  std::lock_guard lock(mutex_);
  auto* list = new RTC::PortServiceList;
  list->length(static_cast<CORBA::ULong>(ports_.size()));
  for (CORBA::ULong i = 0; i < ports_.size(); ++i) (*list)[i] = ports_[i]->reference();
  return list;
}

// ---- SDO: what URSLink does not offer, answered as the specification allows ----

SDOPackage::OrganizationList* Component::get_owned_organizations() { return new SDOPackage::OrganizationList; }
char* Component::get_sdo_id() { return CORBA::string_dup(instance_name_.c_str()); }
char* Component::get_sdo_type() { return CORBA::string_dup(info_.type_name.c_str()); }

SDOPackage::DeviceProfile* Component::get_device_profile() {
  auto* profile = new SDOPackage::DeviceProfile;
  profile->device_type = CORBA::string_dup(info_.category.c_str());
  profile->manufacturer = CORBA::string_dup(info_.vendor.c_str());
  profile->model = CORBA::string_dup(info_.type_name.c_str());
  profile->version = CORBA::string_dup(info_.version.c_str());
  return profile;
}

SDOPackage::ServiceProfileList* Component::get_service_profiles() { return new SDOPackage::ServiceProfileList; }

SDOPackage::ServiceProfile* Component::get_service_profile(const char* id) {
  throw SDOPackage::InvalidParameter((std::string("no SDO service profile with id ") + id).c_str());
}

SDOPackage::SDOService_ptr Component::get_sdo_service(const char* id) {
  throw SDOPackage::InvalidParameter((std::string("no SDO service with id ") + id).c_str());
}

SDOPackage::Configuration_ptr Component::get_configuration() {
  return SDOPackage::Configuration::_duplicate(configuration_ref_.in());
}

SDOPackage::Monitoring_ptr Component::get_monitoring() {
  throw SDOPackage::InterfaceNotImplemented("URSLink components have no SDO Monitoring interface");
}

SDOPackage::OrganizationList* Component::get_organizations() { return new SDOPackage::OrganizationList; }
SDOPackage::NVList* Component::get_status_list() { return new SDOPackage::NVList; }

CORBA::Any* Component::get_status(const char* name) {
  throw SDOPackage::InvalidParameter((std::string("no status named ") + name).c_str());
}

}  // namespace urs::rtc
