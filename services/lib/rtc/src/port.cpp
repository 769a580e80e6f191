#include "urs/rtc/port.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <optional>
#include <random>

#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::rtc {
namespace {

// Bound on asking one peer port whether it still exists, when a profile is read or a connection made.
constexpr std::chrono::milliseconds kPeerProbeTimeout{500};
// How long a peer that did not answer is not asked again.
constexpr std::chrono::seconds kQuietPeerRetry{10};

const RTC::ConnectorProfile* find_connection(const std::vector<RTC::ConnectorProfile>& list, const std::string& id) {
  for (const auto& profile : list) {
    if (id == profile.connector_id.in()) return &profile;
  }
  return nullptr;
}

// A copy of the connection `id` of `list`, read under `mutex`; nullopt if there is none.
std::optional<RTC::ConnectorProfile> copy_connection(std::mutex& mutex, const std::vector<RTC::ConnectorProfile>& list,
                                                     const std::string& id) {
  std::lock_guard lock(mutex);
  const RTC::ConnectorProfile* found = find_connection(list, id);
  if (found == nullptr) return std::nullopt;
  return *found;
}

}  // namespace

std::string make_uuid() {
  static thread_local std::mt19937_64 random{std::random_device{}()};
  const std::uint64_t high = random();
  const std::uint64_t low = random();
  char text[37];
  std::snprintf(text, sizeof text, "%08x-%04x-4%03x-%04x-%012llx", static_cast<unsigned>(high >> 32),
                static_cast<unsigned>((high >> 16) & 0xffff), static_cast<unsigned>(high & 0x0fff),
                static_cast<unsigned>(((low >> 48) & 0x3fff) | 0x8000),
                static_cast<unsigned long long>(low & 0xffffffffffffULL));
  return text;
}

PortBase::PortBase(std::string name, std::string port_type) : short_name_(std::move(name)) {
  nv_set(properties_, "port.port_type", port_type);
}

PortBase::~PortBase() {
  // A port destroyed without detach() (its component never exited) must not stay reachable.
  if (orb_ != nullptr) orb_->deactivate(this);
}

std::string PortBase::name() const {
  std::lock_guard lock(mutex_);
  return instance_name_.empty() ? short_name_ : instance_name_ + "." + short_name_;
}

std::string PortBase::instance_name() const {
  std::lock_guard lock(mutex_);
  return instance_name_;
}

RTC::PortService_ptr PortBase::reference() const {
  std::lock_guard lock(mutex_);
  return RTC::PortService::_duplicate(self_.in());
}

void PortBase::attach(Orb& orb, const std::string& instance_name, RTC::RTObject_ptr owner) {
  {
    std::lock_guard lock(mutex_);
    orb_ = &orb;
    instance_name_ = instance_name;
    owner_ = RTC::RTObject::_duplicate(owner);
  }
  CORBA::Object_var object = orb.activate(this);
  RTC::PortService_var self = RTC::PortService::_narrow(object);
  {
    std::lock_guard lock(mutex_);
    self_ = self;
  }
  attached();
}

void PortBase::detach() {
  if (orb_ == nullptr) return;
  try {
    disconnect_all();
  } catch (const CORBA::Exception& e) {
    spdlog::warn("port {}: disconnecting on detach: {}", name(), describe(e));
  }
  detaching();
  orb_->deactivate(this);
  orb_ = nullptr;
}

void PortBase::add_interface(const std::string& instance_name, const std::string& type_name,
                             RTC::PortInterfacePolarity polarity) {
  std::lock_guard lock(mutex_);
  const CORBA::ULong n = interfaces_.length();
  interfaces_.length(n + 1);
  interfaces_[n].instance_name = CORBA::string_dup(instance_name.c_str());
  interfaces_[n].type_name = CORBA::string_dup(type_name.c_str());
  interfaces_[n].polarity = polarity;
}

void PortBase::set_property(const std::string& name, const std::string& value) {
  std::lock_guard lock(mutex_);
  nv_set(properties_, name, value);
}

int PortBase::index_in(const RTC::ConnectorProfile& profile) const {
  RTC::PortService_var self = reference();
  if (CORBA::is_nil(self)) return -1;
  for (CORBA::ULong i = 0; i < profile.ports.length(); ++i) {
    try {
      if (!CORBA::is_nil(profile.ports[i]) && profile.ports[i]->_is_equivalent(self)) return static_cast<int>(i);
    } catch (const CORBA::SystemException&) {
    }
  }
  return -1;
}

std::size_t PortBase::connection_count() const {
  std::lock_guard lock(mutex_);
  return connections_.size();
}

std::vector<RTC::ConnectorProfile> PortBase::connections() const {
  std::lock_guard lock(mutex_);
  return connections_;
}

// ---- profiles ----

RTC::PortProfile* PortBase::get_port_profile() {
  drop_dead_connections();
  std::lock_guard lock(mutex_);
  auto* profile = new RTC::PortProfile;
  profile->name =
      CORBA::string_dup((instance_name_.empty() ? short_name_ : instance_name_ + "." + short_name_).c_str());
  profile->interfaces = interfaces_;
  profile->port_ref = RTC::PortService::_duplicate(self_.in());
  profile->connector_profiles.length(static_cast<CORBA::ULong>(connections_.size()));
  for (CORBA::ULong i = 0; i < connections_.size(); ++i) profile->connector_profiles[i] = connections_[i];
  profile->owner = RTC::RTObject::_duplicate(owner_.in());
  profile->properties = properties_;
  return profile;
}

RTC::ConnectorProfileList* PortBase::get_connector_profiles() {
  drop_dead_connections();
  std::lock_guard lock(mutex_);
  auto* list = new RTC::ConnectorProfileList;
  list->length(static_cast<CORBA::ULong>(connections_.size()));
  for (CORBA::ULong i = 0; i < connections_.size(); ++i) (*list)[i] = connections_[i];
  return list;
}

RTC::ConnectorProfile* PortBase::get_connector_profile(const char* connector_id) {
  std::lock_guard lock(mutex_);
  const RTC::ConnectorProfile* found = find_connection(connections_, connector_id);
  // The specification returns an empty profile for an unknown id.
  return found ? new RTC::ConnectorProfile(*found) : new RTC::ConnectorProfile;
}

// ---- connecting ----

bool PortBase::already_connected_to(const RTC::ConnectorProfile& profile) const {
  for (CORBA::ULong i = 0; i < profile.ports.length(); ++i) {
    const RTC::PortService_ptr other = profile.ports[i];
    if (CORBA::is_nil(other) || (!CORBA::is_nil(self_) && other->_is_equivalent(self_))) continue;
    for (const auto& existing : connections_) {
      for (CORBA::ULong j = 0; j < existing.ports.length(); ++j) {
        try {
          if (!CORBA::is_nil(existing.ports[j]) && existing.ports[j]->_is_equivalent(other)) return true;
        } catch (const CORBA::SystemException&) {
        }
      }
    }
  }
  return false;
}

RTC::ReturnCode_t PortBase::connect(RTC::ConnectorProfile& connector_profile) {
  if (connector_profile.ports.length() == 0 || CORBA::is_nil(connector_profile.ports[0])) {
    spdlog::warn("port {}: connect refused: the connector profile names no ports", name());
    return RTC::BAD_PARAMETER;
  }
  drop_dead_connections();
  if (std::string(connector_profile.connector_id.in()).empty()) {
    connector_profile.connector_id = CORBA::string_dup(make_uuid().c_str());
  } else {
    std::lock_guard lock(mutex_);
    if (find_connection(connections_, connector_profile.connector_id.in()) != nullptr) {
      spdlog::warn("port {}: connect refused: connector id {} is already in use", short_name_,
                   connector_profile.connector_id.in());
      return RTC::BAD_PARAMETER;
    }
  }
  try {
    return connector_profile.ports[0]->notify_connect(connector_profile);
  } catch (const CORBA::SystemException& e) {
    spdlog::warn("port {}: connect: the first port of the connection does not answer: {}", name(), describe(e));
    return RTC::RTC_ERROR;
  }
}

RTC::ReturnCode_t PortBase::notify_connect(RTC::ConnectorProfile& connector_profile) {
  const std::string id = connector_profile.connector_id.in();
  const int index = index_in(connector_profile);
  if (index < 0) {
    spdlog::warn("port {}: notify_connect for connector {} that does not list this port", name(), id);
    return RTC::BAD_PARAMETER;
  }
  {
    std::string allow = nv_string(connector_profile.properties, "dataport.allow_dup_connection").value_or("");
    for (char& c : allow) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    std::lock_guard lock(mutex_);
    if (allow != "YES" && already_connected_to(connector_profile)) {
      spdlog::warn(
          "port {}: connection {} refused: this port is already connected to a port of it "
          "(dataport.allow_dup_connection=YES allows it)",
          short_name_, id);
      return RTC::PRECONDITION_NOT_MET;
    }
  }

  RTC::ReturnCode_t result = publish_interfaces(connector_profile);
  if (result != RTC::RTC_OK) {
    spdlog::warn("port {}: connection {}: publishing interfaces failed: {}", name(), id, return_code_name(result));
    return result;
  }
  // Pass the profile on: what later ports publish comes back in `connector_profile`.
  const CORBA::ULong next = static_cast<CORBA::ULong>(index) + 1;
  if (next < connector_profile.ports.length()) {
    try {
      result = connector_profile.ports[next]->notify_connect(connector_profile);
    } catch (const CORBA::SystemException& e) {
      spdlog::warn("port {}: connection {}: port {} of the connection does not answer: {}", name(), id, next,
                   describe(e));
      result = RTC::RTC_ERROR;
    }
    if (result != RTC::RTC_OK) {
      unsubscribe_interfaces(connector_profile);  // retires what publish_interfaces created
      forget_after(connector_profile, next);
      return result;
    }
  }
  result = subscribe_interfaces(connector_profile);
  if (result != RTC::RTC_OK) {
    spdlog::warn("port {}: connection {}: subscribing interfaces failed: {}", name(), id, return_code_name(result));
    unsubscribe_interfaces(connector_profile);
    forget_after(connector_profile, next);
    return result;
  }
  std::lock_guard lock(mutex_);
  for (auto& existing : connections_) {
    if (id == existing.connector_id.in()) {
      existing = connector_profile;
      return RTC::RTC_OK;
    }
  }
  connections_.push_back(connector_profile);
  spdlog::debug("port {}: connected {} ({})", instance_name_ + "." + short_name_, id, connector_profile.name.in());
  return RTC::RTC_OK;
}

void PortBase::forget_after(const RTC::ConnectorProfile& profile, CORBA::ULong next) {
  // The ports after this one may already hold the connection that failed here: they drop it.
  if (next >= profile.ports.length()) return;
  try {
    profile.ports[next]->notify_disconnect(profile.connector_id.in());
  } catch (const CORBA::SystemException& e) {
    spdlog::debug("port {}: abandoning connection {}: port {} does not answer: {}", name(), profile.connector_id.in(),
                  next, describe(e));
  }
}

// ---- disconnecting ----

RTC::ReturnCode_t PortBase::disconnect(const char* connector_id) {
  auto profile = copy_connection(mutex_, connections_, connector_id);
  if (!profile) return RTC::BAD_PARAMETER;
  // The first port that answers runs the disconnection along the chain.
  for (CORBA::ULong i = 0; i < profile->ports.length(); ++i) {
    try {
      const RTC::ReturnCode_t result = profile->ports[i]->notify_disconnect(connector_id);
      if (drop_connection(connector_id)) {
        spdlog::debug("port {}: connection {} removed locally after notify_disconnect", name(), connector_id);
      }
      return result;
    } catch (const CORBA::SystemException& e) {
      spdlog::debug("port {}: disconnect {}: port {} does not answer: {}", name(), connector_id, i, describe(e));
    }
  }
  drop_connection(connector_id);
  return RTC::RTC_OK;
}

RTC::ReturnCode_t PortBase::notify_disconnect(const char* connector_id) {
  auto profile = copy_connection(mutex_, connections_, connector_id);
  if (!profile) return RTC::BAD_PARAMETER;
  const int index = index_in(*profile);
  // Ports after this one hear of it even if one of them is gone.
  for (CORBA::ULong i = static_cast<CORBA::ULong>(index) + 1; index >= 0 && i < profile->ports.length(); ++i) {
    try {
      profile->ports[i]->notify_disconnect(connector_id);
      break;
    } catch (const CORBA::SystemException& e) {
      spdlog::debug("port {}: notify_disconnect {}: port {} does not answer: {}", name(), connector_id, i, describe(e));
    }
  }
  erase_connection(connector_id);
  return RTC::RTC_OK;
}

RTC::ReturnCode_t PortBase::disconnect_all() {
  std::vector<std::string> ids;
  {
    std::lock_guard lock(mutex_);
    for (const auto& profile : connections_) ids.emplace_back(profile.connector_id.in());
  }
  RTC::ReturnCode_t result = RTC::RTC_OK;
  for (const auto& id : ids) {
    if (disconnect(id.c_str()) != RTC::RTC_OK) result = RTC::RTC_ERROR;
  }
  return result;
}

void PortBase::erase_connection(const std::string& connector_id) {
  RTC::ConnectorProfile profile;
  {
    std::lock_guard lock(mutex_);
    auto it = std::find_if(connections_.begin(), connections_.end(),
                           [&](const RTC::ConnectorProfile& p) { return connector_id == p.connector_id.in(); });
    if (it == connections_.end()) return;
    profile = *it;
    connections_.erase(it);
  }
  unsubscribe_interfaces(profile);
  spdlog::debug("port {}: disconnected {}", name(), connector_id);
}

bool PortBase::drop_connection(const std::string& connector_id) {
  {
    std::lock_guard lock(mutex_);
    if (find_connection(connections_, connector_id) == nullptr) return false;
  }
  erase_connection(connector_id);
  return true;
}

bool PortBase::peer_gone(Orb& orb, RTC::PortService_ptr peer) {
  const std::string key = orb.object_to_string(peer);
  const auto now = std::chrono::steady_clock::now();
  {
    std::lock_guard lock(mutex_);
    const auto quiet = quiet_peers_.find(key);
    if (quiet != quiet_peers_.end() && now < quiet->second) return false;
  }
  // Bounded, so that a paused or slow peer cannot hold up the reading of this profile; a peer
  // that does not answer in time is kept (slowness is not death) and left alone for a while,
  // since the next probe would have to open a new connection, which takes omniORB's connect
  // timeout instead of this bound.
  CORBA::Object_var probe = orb.bounded(peer, kPeerProbeTimeout);
  const Liveness answer = liveness(probe);
  std::lock_guard lock(mutex_);
  if (answer == Liveness::kNoAnswer) {
    quiet_peers_[key] = now + kQuietPeerRetry;
    spdlog::info("port {}: a peer port does not answer within {} ms; its connection is kept", short_name_,
                 kPeerProbeTimeout.count());
  } else {
    quiet_peers_.erase(key);
  }
  return answer == Liveness::kGone;
}

int PortBase::drop_dead_connections() {
  std::vector<RTC::ConnectorProfile> snapshot;
  {
    std::lock_guard lock(mutex_);
    snapshot = connections_;
  }
  Orb* orb = nullptr;
  {
    std::lock_guard lock(mutex_);
    orb = orb_;
  }
  if (orb == nullptr) return 0;
  int dropped = 0;
  for (const auto& profile : snapshot) {
    const int self = index_in(profile);
    bool dead = false;
    for (CORBA::ULong i = 0; i < profile.ports.length() && !dead; ++i) {
      if (static_cast<int>(i) == self) continue;
      dead = peer_gone(*orb, profile.ports[i]);
    }
    if (dead) {
      spdlog::info("port {}: dropping connection {}: a peer port no longer exists", name(), profile.connector_id.in());
      if (drop_connection(profile.connector_id.in())) ++dropped;
    }
  }
  return dropped;
}

}  // namespace urs::rtc
