#include "urs/rtc/corba_port.hpp"

#include <spdlog/spdlog.h>

#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"

namespace urs::rtc {

CORBA::Object_ptr Consumer::object() const {
  std::lock_guard lock(mutex_);
  return CORBA::Object::_duplicate(object_.in());
}

bool Consumer::connected() const {
  std::lock_guard lock(mutex_);
  return !CORBA::is_nil(object_);
}

void Consumer::set(CORBA::Object_ptr object, const std::string& connector_id) {
  std::lock_guard lock(mutex_);
  object_ = CORBA::Object::_duplicate(object);
  connector_id_ = connector_id;
}

void Consumer::clear(const std::string& connector_id) {
  std::lock_guard lock(mutex_);
  if (connector_id != connector_id_) return;
  object_ = CORBA::Object::_nil();
  connector_id_.clear();
}

CorbaPort::CorbaPort(std::string name) : PortBase(std::move(name), "CorbaPort") {}

CorbaPort::~CorbaPort() {
  if (attached_) detaching();
}

void CorbaPort::provide(const std::string& instance_name, const std::string& type_name,
                        PortableServer::ServantBase& servant) {
  add_interface(instance_name, type_name, RTC::PROVIDED);
  std::lock_guard lock(mutex_);
  providers_.push_back({instance_name, type_name, &servant, {}});
}

Consumer& CorbaPort::require(const std::string& instance_name, const std::string& type_name) {
  add_interface(instance_name, type_name, RTC::REQUIRED);
  std::lock_guard lock(mutex_);
  consumers_.push_back(std::make_unique<Consumer>(instance_name, type_name));
  return *consumers_.back();
}

void CorbaPort::attached() {
  std::lock_guard lock(mutex_);
  attached_ = true;
  for (auto& provider : providers_) {
    CORBA::Object_var object = orb().activate(provider.servant);
    provider.ior = orb().object_to_string(object);
    provider.id = orb().poa()->reference_to_id(object);
    provider.active = true;
  }
}

void CorbaPort::detaching() {
  std::lock_guard lock(mutex_);
  attached_ = false;
  for (auto& provider : providers_) {
    if (provider.active) orb().deactivate(provider.servant);
    provider.active = false;
  }
}

void CorbaPort::activate_interfaces() {
  std::lock_guard lock(mutex_);
  if (!attached_) return;
  for (auto& provider : providers_) {
    if (provider.active) continue;
    orb().poa()->activate_object_with_id(provider.id.in(), provider.servant);
    provider.active = true;
  }
}

void CorbaPort::deactivate_interfaces() {
  std::lock_guard lock(mutex_);
  for (auto& provider : providers_) {
    if (!provider.active) continue;
    orb().deactivate(provider.servant);
    provider.active = false;
  }
}

std::string CorbaPort::provided_key(const Provider& provider) const {
  return instance_name() + ".port." + short_name() + ".provided." + provider.type_name + "." + provider.instance_name;
}

std::string CorbaPort::required_key(const Consumer& consumer) const {
  return instance_name() + ".port." + short_name() + ".required." + consumer.type_name() + "." +
         consumer.instance_name();
}

RTC::ReturnCode_t CorbaPort::publish_interfaces(RTC::ConnectorProfile& profile) {
  std::lock_guard lock(mutex_);
  for (const auto& provider : providers_) {
    nv_set(profile.properties, provided_key(provider), provider.ior);
    nv_set(profile.properties, "port." + provider.type_name + "." + provider.instance_name, provider.ior);
  }
  return RTC::RTC_OK;
}

RTC::ReturnCode_t CorbaPort::subscribe_interfaces(const RTC::ConnectorProfile& profile) {
  const bool strict = nv_string(profile.properties, "port.connection.strictness") == "strict";
  const std::string id = profile.connector_id.in();
  std::lock_guard lock(mutex_);
  for (auto& consumer : consumers_) {
    std::optional<std::string> ior;
    if (const auto provider_key = nv_string(profile.properties, required_key(*consumer))) {
      ior = nv_string(profile.properties, *provider_key);
    }
    if (!ior) ior = nv_string(profile.properties, "port." + consumer->type_name() + "." + consumer->instance_name());
    if (!ior || *ior == "nil" || *ior == "null" || ior->rfind("IOR:", 0) != 0) {
      if (strict) {
        spdlog::warn("port {}: connection {}: no provider for required {} {} (strict)", name(), id,
                     consumer->type_name(), consumer->instance_name());
        return RTC::RTC_ERROR;
      }
      continue;
    }
    try {
      CORBA::Object_var object = orb().string_to_object(*ior);
      consumer->set(object, id);
      spdlog::debug("port {}: consumer {} connected through {}", name(), consumer->instance_name(), id);
    } catch (const std::invalid_argument& e) {
      spdlog::warn("port {}: connection {}: {}", name(), id, e.what());
      if (strict) return RTC::BAD_PARAMETER;
    }
  }
  return RTC::RTC_OK;
}

void CorbaPort::unsubscribe_interfaces(const RTC::ConnectorProfile& profile) {
  std::lock_guard lock(mutex_);
  for (auto& consumer : consumers_) consumer->clear(profile.connector_id.in());
}

}  // namespace urs::rtc
