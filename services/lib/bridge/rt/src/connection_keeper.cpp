#include "connection_keeper.hpp"

#include <spdlog/spdlog.h>

#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/port.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::bridge {

namespace {

using Clock = std::chrono::steady_clock;
constexpr auto kProbeTimeout = std::chrono::milliseconds(500);     // a peer's liveness, a stale half dropped
constexpr auto kProfileTimeout = std::chrono::milliseconds(2000);  // connecting again
constexpr auto kRetryPeriod = std::chrono::milliseconds(2000);

}  // namespace

ConnectionKeeper::ConnectionKeeper(rtc::Orb& orb, std::string path, std::string connector_name)
    : orb_(orb), store_(std::move(path)), connector_name_(std::move(connector_name)) {}

void ConnectionKeeper::load() {
  if (store_.path().empty()) return;
  const std::vector<SavedConnection> saved = store_.load();
  if (!stale_halves_dropped_) {
    // A new process: what the saved connections' peers hold is half of a connection to ports
    // that died with the last one. Dropped by id (notify_disconnect), which reads no profile:
    // an OpenRTM-aist OutPort whose peer was killed crashes on its next profile read.
    stale_halves_dropped_ = true;
    int dropped = 0;
    for (const auto& connection : saved) {
      for (const auto& ior : connection.ports) {
        if (ior.empty()) continue;
        try {
          CORBA::Object_var object = orb_.string_to_object(ior);
          RTC::PortService_var peer = orb_.bounded<RTC::PortService>(object, kProbeTimeout);
          if (peer->notify_disconnect(connection.id.c_str()) == RTC::RTC_OK) ++dropped;
        } catch (const std::exception& e) {
          spdlog::debug("bridge: connection {}: {}", connection.id, e.what());
        } catch (const CORBA::Exception& e) {
          spdlog::debug("bridge: connection {}: a peer port does not answer: {}", connection.id, rtc::describe(e));
        }
      }
    }
    if (!saved.empty()) {
      spdlog::info("bridge: {} connection(s) of its RTCs were kept in {}; {} stale half(s) dropped at their peers",
                   saved.size(), store_.path(), dropped);
    }
  }
  restores_.clear();
  for (const auto& connection : saved) {
    if (!connection.made_by_bridge) restores_.push_back({connection, Clock::now()});  // the rules remake the others
  }
}

void ConnectionKeeper::restore(const FindRtc& find) {
  const auto now = Clock::now();
  for (auto it = restores_.begin(); it != restores_.end();) {
    const SavedConnection& saved = it->saved;
    rtc::Component* component = find(saved.rtc);
    if (component == nullptr || now < it->retry_at) {
      ++it;
      continue;
    }
    rtc::PortBase* ours = nullptr;
    for (rtc::PortBase* port : component->ports()) {
      if (port->short_name() == saved.port) ours = port;
    }
    bool held = false;
    if (ours != nullptr) {
      for (const auto& profile : ours->connections()) held = held || saved.id == profile.connector_id.in();
    }
    const std::string where = component->instance_name() + "." + saved.port;
    if (ours == nullptr || held) {
      if (ours == nullptr) {
        spdlog::warn("bridge: {} has no port {} any more; connection {} is not restored", component->instance_name(),
                     saved.port, saved.id);
      }
      it = restores_.erase(it);
      continue;
    }
    try {
      RTC::PortService_var ours_ref = ours->reference();
      std::vector<RTC::PortService_var> peers;  // own the references while connecting
      peers.reserve(saved.ports.size());
      std::vector<RTC::PortService_ptr> ports;
      bool gone = false;
      for (const auto& ior : saved.ports) {
        if (ior.empty()) {
          ports.push_back(ours_ref.in());
          continue;
        }
        CORBA::Object_var object = orb_.string_to_object(ior);
        peers.push_back(orb_.bounded<RTC::PortService>(object, kProfileTimeout));
        gone = gone || rtc::liveness(peers.back()) == rtc::Liveness::kGone;
        ports.push_back(peers.back().in());
      }
      if (gone) {
        spdlog::info("bridge: connection {} of {} is not restored: a peer port no longer exists", saved.id, where);
        it = restores_.erase(it);
        continue;
      }
      const rtc::Connection made = rtc::connect_ports(
          ports, saved.name, rtc::nv_from({saved.properties.begin(), saved.properties.end()}), saved.id);
      if (made.code == RTC::RTC_OK) {
        spdlog::info("bridge: connection {} ({}) of {} restored", saved.id, saved.name, where);
        warned_.erase(saved.id);
        it = restores_.erase(it);
        continue;
      }
      if (warned_.insert(saved.id).second) {
        spdlog::warn("bridge: restoring connection {} of {}: {}; trying again every {} ms", saved.id, where,
                     rtc::return_code_name(made.code), kRetryPeriod.count());
      }
    } catch (const std::exception& e) {
      if (warned_.insert(saved.id).second) {
        spdlog::warn("bridge: restoring connection {} of {}: {}", saved.id, where, e.what());
      }
    } catch (const CORBA::Exception& e) {
      if (warned_.insert(saved.id).second) {
        spdlog::warn("bridge: restoring connection {} of {}: {}", saved.id, where, rtc::describe(e));
      }
    }
    it->retry_at = now + kRetryPeriod;
    ++it;
  }
}

void ConnectionKeeper::save(const std::vector<std::pair<std::string, rtc::Component*>>& rtcs) {
  if (store_.path().empty()) return;
  const auto ior_of = [this](CORBA::Object_ptr object) { return orb_.object_to_string(object); };
  std::vector<SavedConnection> held;
  for (const auto& [key, component] : rtcs) {
    for (rtc::PortBase* port : component->ports()) {
      RTC::PortService_var ref = port->reference();
      for (const auto& profile : port->connections()) {
        SavedConnection saved;
        if (describe_connection(profile, ref, key, port->short_name(), connector_name_ == profile.name.in(), ior_of,
                                saved)) {
          held.push_back(std::move(saved));
        }
      }
    }
  }
  for (const auto& restore : restores_) held.push_back(restore.saved);  // kept until made again
  store_.save(held);
}

}  // namespace urs::bridge
