#include "urs/rtc/connector.hpp"

#include <fnmatch.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <optional>
#include <set>
#include <utility>

#include "urs/rtc/naming_watch.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::rtc {
namespace {

using Clock = std::chrono::steady_clock;

bool glob_match(const std::string& pattern, const std::string& path) {
  return fnmatch(pattern.c_str(), path.c_str(), 0) == 0;
}

std::chrono::microseconds since(Clock::time_point start) {
  return std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - start);
}

// "<instance>.port.<port>", the prefix OpenRTM-aist's CorbaPort gives its connector keys: the
// full port name "<instance>.<port>" with ".port" inserted after the instance name.
std::string port_key(const std::string& instance, const std::string& port_name) {
  if (port_name.compare(0, instance.size() + 1, instance + ".") == 0) {
    return instance + ".port" + port_name.substr(instance.size());
  }
  return instance + ".port." + port_name;
}

bool is_ior(const std::optional<std::string>& value) { return value && value->compare(0, 4, "IOR:") == 0; }

// If the connection `profile` gives the consumer's required interface (`type`, `instance`) a
// provider, by the rule the consumer applies itself (the "required" key naming a provider key,
// else the old-style key), the provided interface's instance name; nullopt otherwise.
std::optional<std::string> provider_interface_in(const RTC::ConnectorProfile& profile, const std::string& required_key,
                                                 const std::string& type, const std::string& instance) {
  if (const auto provider_key = nv_string(profile.properties, required_key)) {
    if (!is_ior(nv_string(profile.properties, *provider_key))) return std::nullopt;
    const std::string marker = ".provided." + type + ".";
    const auto at = provider_key->rfind(marker);
    return at == std::string::npos ? std::string() : provider_key->substr(at + marker.size());
  }
  if (is_ior(nv_string(profile.properties, "port." + type + "." + instance))) return instance;
  return std::nullopt;
}

}  // namespace

Connector::Connector(Orb& orb, const std::string& naming_address, ConnectorOptions options)
    : orb_(orb), naming_(orb, naming_address), options_(std::move(options)) {}

Connector::~Connector() { stop(); }

void Connector::on_event(std::function<void(const ConnectorEvent&)> listener) { listener_ = std::move(listener); }

void Connector::start() {
  std::lock_guard<std::mutex> thread_lock(thread_mutex_);
  if (thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> poll_lock(poll_mutex_);
    components_.clear();
    std::lock_guard<std::mutex> links_lock(links_mutex_);
    links_.clear();
  }
  stop_requested_ = false;
  thread_ = std::thread([this] { run(); });
}

void Connector::stop() {
  std::thread thread;
  {
    std::lock_guard<std::mutex> lock(thread_mutex_);
    stop_requested_ = true;
    thread = std::move(thread_);
  }
  wake_.notify_all();
  if (thread.joinable()) thread.join();
  stop_requested_ = false;
  if (!options_.disconnect_on_stop) return;
  std::lock_guard<std::mutex> poll_lock(poll_mutex_);
  PollReport report;
  std::vector<Slot> made;
  for (const auto& [slot, link] : links_) {
    if (link.info.made) made.push_back(slot);
  }
  for (const Slot& slot : made) drop_link(slot, End::kConsumer, "connector stopped", report);
}

bool Connector::running() const {
  std::lock_guard<std::mutex> lock(thread_mutex_);
  return thread_.joinable();
}

void Connector::run() {
  bool naming_failing = false;
  auto next = Clock::now();
  std::unique_lock<std::mutex> lock(thread_mutex_);
  while (!stop_requested_) {
    lock.unlock();
    try {
      const PollReport report = poll_once();
      if (!report.naming_error.empty() && !naming_failing) {
        spdlog::warn("connector {}: {} (retrying every poll)", options_.name, report.naming_error);
      } else if (report.naming_error.empty() && naming_failing) {
        spdlog::info("connector {}: naming service {} readable again", options_.name, naming_.address());
      }
      naming_failing = !report.naming_error.empty();
      if (report.fetched + report.connected + report.disconnected > 0) {
        spdlog::debug(
            "connector {}: {} binding(s), {} profile(s) read, {} probe(s), +{} -{} connection(s) in {} us "
            "(naming {} us)",
            options_.name, report.bindings, report.fetched, report.probes, report.connected, report.disconnected,
            report.total_time.count(), report.naming_time.count());
      }
    } catch (const CORBA::Exception& e) {
      spdlog::warn("connector {}: poll failed: {}", options_.name, describe(e));
    } catch (const std::exception& e) {
      spdlog::warn("connector {}: poll failed: {}", options_.name, e.what());
    }
    lock.lock();
    // Fixed-rate polling keeps the detection delay within one period; a poll that overran
    // starts the next one at once instead of making up the missed ones.
    next = std::max(next + options_.poll_period, Clock::now());
    wake_.wait_until(lock, next, [this] { return stop_requested_.load(); });
  }
}

PollReport Connector::poll_once() {
  std::lock_guard<std::mutex> lock(poll_mutex_);
  const auto start = Clock::now();
  PollReport report;
  ComponentBindings bound;
  if (read_naming(bound, report)) {
    forget_changed(bound, report);
    read_components(bound, report);
    probe_providers(report);
    connect_missing(report);
  }
  report.total_time = since(start);
  return report;
}

std::vector<ConnectorLink> Connector::links() const {
  std::lock_guard<std::mutex> lock(links_mutex_);
  std::vector<ConnectorLink> out;
  for (const auto& entry : links_) out.push_back(entry.second.info);
  return out;
}

bool Connector::watched(const std::string& path) const {
  return std::any_of(options_.rules.begin(), options_.rules.end(), [&](const ConnectorRule& rule) {
    return glob_match(rule.consumers, path) || glob_match(rule.providers, path);
  });
}

const ConnectorRule* Connector::rule_for(const std::string& consumer_path, const std::string& type) const {
  for (const ConnectorRule& rule : options_.rules) {
    if (rule.interface == type && glob_match(rule.consumers, consumer_path)) return &rule;
  }
  return nullptr;
}

bool Connector::read_naming(ComponentBindings& bound, PollReport& report) {
  const auto start = Clock::now();
  try {
    auto read = read_component_bindings(
        naming_, orb_, [this](const std::string& path) { return watched(path); }, [this] { return stopping(); });
    if (!read) return false;
    bound = std::move(*read);
  } catch (const NamingError& e) {
    report.naming_error = e.what();
    return false;
  }
  report.bindings = bound.size();
  report.naming_time = since(start);
  return true;
}

void Connector::forget_changed(const ComponentBindings& bound, PollReport& report) {
  for (const auto& changed :
       changed_bindings(components_, bound, [](const Component& component) { return component.ior; })) {
    drop_links_of(changed.path, "provider " + changed.why, "consumer " + changed.why, report);
    components_.erase(changed.path);
  }
}

void Connector::read_components(const ComponentBindings& bound, PollReport& report) {
  const auto now = Clock::now();
  std::vector<std::string> fresh;
  for (const auto& [path, w] : bound) {
    if (stopping()) return;
    const auto known = components_.find(path);
    if (known != components_.end() && (known->second.reachable || now < known->second.retry_at)) continue;
    ++report.fetched;
    const Component& component = components_[path] = read_component(w.object, w.ior);
    if (component.reachable) {
      spdlog::debug("connector {}: {} ({} service port(s))", options_.name, path, component.ports.size());
      fresh.push_back(path);
    }
  }
  // After all are read, so that a connection to a provider read in this poll is recognised.
  for (const std::string& path : fresh) adopt_connections(path, components_.at(path), report);
}

Connector::Component Connector::read_component(CORBA::Object_ptr object, const std::string& ior) {
  Component component;
  component.ior = ior;
  try {
    // Unchecked: a binding of kind "rtc" is taken to be an RTObject, saving an _is_a round trip;
    // anything else fails the call below and is treated as unreachable.
    RTC::RTObject_var rtc = RTC::RTObject::_unchecked_narrow(object);
    RTC::ComponentProfile_var profile = rtc->get_component_profile();
    component.instance = profile->instance_name.in();
    for (CORBA::ULong i = 0; i < profile->port_profiles.length(); ++i) {
      const RTC::PortProfile& port = profile->port_profiles[i];
      if (nv_string(port.properties, "port.port_type") != "CorbaPort" || CORBA::is_nil(port.port_ref)) continue;
      ServicePort service;
      service.name = port.name.in();
      service.ref = RTC::PortService::_duplicate(port.port_ref);
      for (CORBA::ULong j = 0; j < port.interfaces.length(); ++j) {
        const RTC::PortInterfaceProfile& iface = port.interfaces[j];
        auto& list = iface.polarity == RTC::PROVIDED ? service.provided : service.required;
        list.push_back({iface.instance_name.in(), iface.type_name.in()});
      }
      std::sort(service.provided.begin(), service.provided.end(),
                [](const Interface& a, const Interface& b) { return a.instance < b.instance; });
      service.connectors = port.connector_profiles;
      component.ports.push_back(std::move(service));
    }
    std::sort(component.ports.begin(), component.ports.end(),
              [](const ServicePort& a, const ServicePort& b) { return a.name < b.name; });
    component.probe = make_probe(object);
    component.reachable = true;
  } catch (const CORBA::SystemException& e) {
    spdlog::debug("connector {}: component not answering ({}); reading it again in {} ms", options_.name, describe(e),
                  options_.retry_period.count());
    component.retry_at = Clock::now() + options_.retry_period;
  }
  return component;
}

void Connector::adopt_connections(const std::string& path, Component& component, PollReport& report) {
  for (ServicePort& port : component.ports) {
    for (const Interface& required : port.required) {
      const Slot slot{path, port.name, required.type, required.instance};
      if (rule_for(path, required.type) == nullptr || links_.count(slot) > 0) continue;
      const std::string required_key =
          port_key(component.instance, port.name) + ".required." + required.type + "." + required.instance;
      for (CORBA::ULong i = 0; i < port.connectors.length(); ++i) {
        const RTC::ConnectorProfile& connection = port.connectors[i];
        const auto provider_interface =
            provider_interface_in(connection, required_key, required.type, required.instance);
        if (!provider_interface) continue;
        RTC::PortService_var peer;
        for (CORBA::ULong j = 0; j < connection.ports.length() && CORBA::is_nil(peer); ++j) {
          const RTC::PortService_ptr other = connection.ports[j];
          if (!CORBA::is_nil(other) && !other->_is_equivalent(port.ref)) peer = RTC::PortService::_duplicate(other);
        }
        if (CORBA::is_nil(peer)) continue;
        Link link;
        link.info.interface = required.type;
        link.info.consumer = path;
        link.info.consumer_port = port.name;
        link.info.consumer_interface = required.instance;
        link.info.provider_interface = *provider_interface;
        link.info.connector_id = connection.connector_id.in();
        link.info.made = nv_string(connection.properties, "urslink.connector") == options_.name;
        link.consumer_port = RTC::PortService::_duplicate(port.ref);
        link.provider_port = peer;
        CORBA::Object_var probe = locate_provider(peer, link.info);
        if (CORBA::is_nil(probe)) link.provider_probe = probe = make_probe(peer);
        if (probe_gone(probe, report)) {
          // A connection to a dead provider: remove it so that the consumer holds no stale
          // reference once it is connected to a live one.
          spdlog::info("connector {}: {} {}: removing connection {} to a provider that does not answer", options_.name,
                       path, port.name, link.info.connector_id);
          try {
            port.ref->disconnect(connection.connector_id);
          } catch (const CORBA::SystemException&) {
          }
          continue;
        }
        if (link.info.provider_port.empty()) {
          try {
            RTC::PortProfile_var profile = peer->get_port_profile();
            link.info.provider_port = profile->name.in();
          } catch (const CORBA::SystemException&) {
          }
        }
        spdlog::info("connector {}: {} {} already connected to {} {} ({})", options_.name, path, port.name,
                     link.info.provider.empty() ? "a port outside the naming service" : link.info.provider,
                     link.info.provider_port, required.type);
        ConnectorEvent event{ConnectorEvent::Kind::kConnected, link.info, "found connected"};
        {
          std::lock_guard<std::mutex> lock(links_mutex_);
          links_.emplace(slot, std::move(link));
        }
        emit(event);
        break;
      }
    }
    // Examined once: later changes show up as a new profile when the component is replaced.
    port.connectors.length(0);
  }
}

CORBA::Object_ptr Connector::locate_provider(RTC::PortService_ptr port, ConnectorLink& info) const {
  for (const auto& [path, component] : components_) {
    if (!component.reachable) continue;
    for (const ServicePort& candidate : component.ports) {
      if (candidate.ref->_is_equivalent(port)) {
        info.provider = path;
        info.provider_port = candidate.name;
        return CORBA::Object::_duplicate(component.probe);
      }
    }
  }
  return CORBA::Object::_nil();
}

void Connector::probe_providers(PollReport& report) {
  std::set<std::string> providers;  // probed once per component, however many consumers it has
  std::vector<Slot> outside;        // providers not in the naming service: probed per connection
  for (const auto& [slot, link] : links_) {
    if (link.info.provider.empty()) {
      outside.push_back(slot);
    } else {
      providers.insert(link.info.provider);
    }
  }
  for (const std::string& path : providers) {
    if (stopping()) return;
    if (probe_gone(components_.at(path).probe, report)) mark_unreachable(path, report);
  }
  for (const Slot& slot : outside) {
    if (stopping()) return;
    const auto it = links_.find(slot);
    if (it != links_.end() && probe_gone(it->second.provider_probe, report)) {
      drop_link(slot, End::kConsumer, "provider not answering", report);
    }
  }
}

void Connector::connect_missing(PollReport& report) {
  for (const auto& [path, component] : components_) {
    for (const ServicePort& port : component.ports) {
      for (const Interface& required : port.required) {
        if (stopping() || !component.reachable) return;
        const ConnectorRule* rule = rule_for(path, required.type);
        const Slot slot{path, port.name, required.type, required.instance};
        if (rule == nullptr || links_.count(slot) > 0) continue;
        connect_slot(slot, *rule, component, port, required, report);
      }
    }
  }
}

void Connector::connect_slot(const Slot& slot, const ConnectorRule& rule, const Component& consumer,
                             const ServicePort& consumer_port, const Interface& required, PollReport& report) {
  struct Candidate {
    const std::string& path;
    const Component& component;
    const ServicePort& port;
    const Interface& provided;
  };
  const std::string& consumer_path = std::get<0>(slot);
  std::vector<Candidate> candidates;  // in naming-path, port-name, interface-name order
  for (const auto& [path, provider] : components_) {
    if (!provider.reachable || !glob_match(rule.providers, path)) continue;
    for (const ServicePort& port : provider.ports) {
      if (path == consumer_path && port.name == consumer_port.name) continue;
      for (const Interface& provided : port.provided) {
        if (provided.type == required.type) candidates.push_back({path, provider, port, provided});
      }
    }
  }
  for (const Candidate& c : candidates) {
    if (stopping() || !consumer.reachable) return;
    if (!c.component.reachable) continue;
    if (probe_gone(c.component.probe, report)) {
      mark_unreachable(c.path, report);
      continue;
    }
    const SDOPackage::NVList extra = nv_from({
        {port_key(consumer.instance, consumer_port.name) + ".required." + required.type + "." + required.instance,
         port_key(c.component.instance, c.port.name) + ".provided." + c.provided.type + "." + c.provided.instance},
        {"urslink.connector", options_.name},
    });
    const std::string what = consumer_path + " " + consumer_port.name + " to " + c.path + " " + c.port.name;
    try {
      const Connection connection = connect_ports({consumer_port.ref.in(), c.port.ref.in()}, options_.name, extra);
      if (connection.code != RTC::RTC_OK) {
        spdlog::warn("connector {}: connecting {}: {}", options_.name, what, return_code_name(connection.code));
        continue;
      }
      Link link;
      link.info = {required.type, consumer_path, consumer_port.name,  required.instance,
                   c.path,        c.port.name,   c.provided.instance, connection.profile.connector_id.in(),
                   true};
      link.consumer_port = RTC::PortService::_duplicate(consumer_port.ref);
      link.provider_port = RTC::PortService::_duplicate(c.port.ref);
      ConnectorEvent event{ConnectorEvent::Kind::kConnected, link.info, "connected"};
      {
        std::lock_guard<std::mutex> lock(links_mutex_);
        links_.emplace(slot, std::move(link));
      }
      ++report.connected;
      spdlog::info("connector {}: connected {} ({})", options_.name, what, required.type);
      emit(event);
      return;
    } catch (const CORBA::SystemException& e) {
      spdlog::warn("connector {}: connecting {}: {}", options_.name, what, describe(e));
      if (probe_gone(consumer.probe, report)) mark_unreachable(consumer_path, report);
    }
  }
}

CORBA::Object_ptr Connector::make_probe(CORBA::Object_ptr object) const {
  // A reference of the connector's own, so that the short timeout does not bound other calls.
  return orb_.bounded(object, options_.probe_timeout);
}

bool Connector::probe_gone(CORBA::Object_ptr probe, PollReport& report) const {
  ++report.probes;
  return is_gone(probe);
}

void Connector::mark_unreachable(const std::string& path, PollReport& report) {
  Component& component = components_.at(path);
  component.reachable = false;
  component.retry_at = Clock::now() + options_.retry_period;
  drop_links_of(path, "provider not answering", "consumer not answering", report);
}

void Connector::drop_links_of(const std::string& path, const std::string& as_provider, const std::string& as_consumer,
                              PollReport& report) {
  std::vector<Slot> slots;
  for (const auto& [slot, link] : links_) {
    if (link.info.provider == path || link.info.consumer == path) slots.push_back(slot);
  }
  for (const Slot& slot : slots) {
    // Ask the end that is still there: the consumer when the provider went, and vice versa.
    if (links_.at(slot).info.provider == path) {
      drop_link(slot, End::kConsumer, as_provider, report);
    } else {
      drop_link(slot, End::kProvider, as_consumer, report);
    }
  }
}

void Connector::drop_link(const Slot& slot, End ask, const std::string& reason, PollReport& report) {
  Link link;
  {
    std::lock_guard<std::mutex> lock(links_mutex_);
    auto it = links_.find(slot);
    if (it == links_.end()) return;
    link = it->second;
    links_.erase(it);
  }
  RTC::PortService_ptr port = ask == End::kConsumer ? link.consumer_port.in() : link.provider_port.in();
  try {
    const RTC::ReturnCode_t code = port->disconnect(link.info.connector_id.c_str());
    spdlog::debug("connector {}: disconnect {}: {}", options_.name, link.info.connector_id, return_code_name(code));
  } catch (const CORBA::SystemException& e) {
    spdlog::debug("connector {}: disconnect {}: {}", options_.name, link.info.connector_id, describe(e));
  }
  ++report.disconnected;
  spdlog::info("connector {}: disconnected {} {} from {} {} ({})", options_.name, link.info.consumer,
               link.info.consumer_port, link.info.provider, link.info.provider_port, reason);
  emit({ConnectorEvent::Kind::kDisconnected, link.info, reason});
}

void Connector::emit(const ConnectorEvent& event) {
  if (listener_) listener_(event);
}

}  // namespace urs::rtc
