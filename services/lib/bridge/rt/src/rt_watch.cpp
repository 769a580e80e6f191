#include "rt_watch.hpp"

#include <omniORB4/minorCode.h>
#include <spdlog/spdlog.h>

#include <cctype>

#include "urs/corba_agent/corba_proxy.hpp"
#include "urs/rt_call/provider_port.hpp"
#include "urs/rtc/data_port.hpp"
#include "urs/rtc/naming_watch.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::bridge {

namespace {

using Clock = std::chrono::steady_clock;
constexpr auto kProbeTimeout = std::chrono::milliseconds(500);     // liveness probe of a provider
constexpr auto kProfileTimeout = std::chrono::milliseconds(2000);  // reading a component's profile
constexpr auto kRetryPeriod = std::chrono::milliseconds(2000);     // a component that did not answer
constexpr const char* kConnectorName = "urs-bridge";

std::string nv_text(const SDOPackage::NVList& list, const char* name) {
  return rtc::nv_string(list, name).value_or("");
}

// How a component answered a probe. Slowness is not death: only an object that does not exist,
// or a process that refuses the connection, is gone; a call that timed out or a connection cut
// mid-call says nothing yet (the next probe will).
enum class Answer { kAlive, kSlow, kGone };

Answer answer_of(const CORBA::SystemException& e) {
  if (dynamic_cast<const CORBA::TIMEOUT*>(&e) != nullptr || dynamic_cast<const CORBA::COMM_FAILURE*>(&e) != nullptr) {
    return Answer::kSlow;
  }
  if (dynamic_cast<const CORBA::TRANSIENT*>(&e) != nullptr) {
    return e.minor() == omni::TRANSIENT_CallTimedout ? Answer::kSlow : Answer::kGone;
  }
  return Answer::kGone;  // OBJECT_NOT_EXIST, INV_OBJREF, ...
}

// What `urs ls` shows for an RT provider (property urslink.health): "ok" while its component is
// Active and answers, else why not.
std::string health_word(bool slow, bool state_known, RTC::LifeCycleState state) {
  if (slow) return "slow";
  if (!state_known || state == RTC::ACTIVE) return "ok";
  std::string word = rtc::state_name(state);
  for (char& c : word) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return word;
}

}  // namespace

struct RtWatch::Known {
  struct Port {
    std::string name;  // short name
    std::string kind;  // port.port_type
    std::string data_type;
    std::vector<std::pair<std::string, std::string>> provided;  // (type_name, instance_name)
    RTC::PortService_var ref;
  };
  std::string ior;
  std::string instance;
  std::string type_name;
  bool reachable = false;
  bool bridged = false;  // carries an origin: something a bridge made
  Clock::time_point retry_at;
  CORBA::Object_var probe;            // the component, calls bounded by kProbeTimeout
  RTC::ExecutionContext_var context;  // its first owned context, bounded the same; nil if none
  bool slow = false;                  // the last probe timed out (it is kept, not withdrawn)
  bool state_known = false;
  RTC::LifeCycleState state = RTC::CREATED;  // in `context`, as last read
  std::vector<Port> ports;
  std::map<std::string, std::string> links;  // "<port>" or "<port>#<our port>" -> connector id we made

  const Port* port(const std::string& link) const {  // the port of a link key
    const std::string name = link.substr(0, link.find('#'));
    for (const auto& entry : ports) {
      if (entry.name == name) return &entry;
    }
    return nullptr;
  }
};

RtWatch::RtWatch(rtc::Orb& orb, rtc::NamingClient& naming, const schema::InterfaceCatalog& catalog,
                 const RtSideConfig& config, BridgeComponent& component, std::string own_path)
    : orb_(orb),
      naming_(naming),
      catalog_(catalog),
      config_(config),
      component_(component),
      own_path_(std::move(own_path)) {}

void RtWatch::watch(bool every_component) {
  // 1. What the naming service holds now (only components some rule may concern); 1 and 2 are
  //    the naming watch rtc::Connector runs too (urs/rtc/naming_watch.hpp).
  auto concerned = [this, every_component](const std::string& path) {
    if (path == own_path_) return false;
    if (every_component) return true;
    for (const auto& rule : config_.providers) {
      if (glob_match(rule.match, path)) return true;
    }
    for (const auto& entry : config_.in) {
      if (glob_match(entry.match, path)) return true;
    }
    for (const auto& entry : config_.out) {
      if (glob_match(entry.match, path)) return true;
    }
    return false;
  };
  rtc::ComponentBindings bound;
  try {
    bound = std::move(*rtc::read_component_bindings(naming_, orb_, concerned));  // never stopped early
  } catch (const std::exception& e) {
    if (warned_.insert("naming").second) spdlog::warn("bridge: naming service {}: {}", naming_.address(), e.what());
    return;
  }
  warned_.erase("naming");

  auto forget = [this](const std::string& path, const std::string& why) {
    auto it = known_.find(path);
    if (it == known_.end()) return;
    for (const auto& [link, connector_id] : it->second->links) {
      spdlog::info("bridge: {} {}: dropping connection {} of its port {}", path, why, connector_id, link);
      drop_link(*it->second, link, connector_id);
    }
    known_.erase(it);
  };

  // 2. Components gone or replaced.
  for (const auto& changed : rtc::changed_bindings(known_, bound, [](const auto& known) { return known->ior; })) {
    forget(changed.path, changed.why);
  }

  // 3. New components: read their ports.
  const auto now = Clock::now();
  for (const auto& [path, binding] : bound) {
    const std::string& ior = binding.ior;
    auto& known = known_[path];
    if (known && (known->reachable || now < known->retry_at)) continue;
    known = std::make_shared<Known>();
    known->ior = ior;
    try {
      CORBA::Object_var object = orb_.string_to_object(ior);
      known->probe = orb_.bounded<CORBA::Object>(object, kProbeTimeout);
      RTC::RTObject_var rtc = orb_.bounded<RTC::RTObject>(object, kProfileTimeout);
      RTC::ComponentProfile_var profile = rtc->get_component_profile();
      known->instance = profile->instance_name.in();
      known->type_name = profile->type_name.in();
      known->bridged = !nv_text(profile->properties, core::kOriginProperty).empty() ||
                       !nv_text(profile->properties, core::kBridgeProperty).empty();
      for (CORBA::ULong i = 0; i < profile->port_profiles.length(); ++i) {
        const RTC::PortProfile& port = profile->port_profiles[i];
        Known::Port entry;
        const std::string full = port.name.in();
        const auto dot = full.find('.');
        entry.name = dot == std::string::npos ? full : full.substr(dot + 1);
        entry.kind = nv_text(port.properties, "port.port_type");
        entry.data_type = nv_text(port.properties, "dataport.data_type");
        for (CORBA::ULong j = 0; j < port.interfaces.length(); ++j) {
          if (port.interfaces[j].polarity == RTC::PROVIDED) {
            entry.provided.emplace_back(port.interfaces[j].type_name.in(), port.interfaces[j].instance_name.in());
          }
        }
        entry.ref = RTC::PortService::_duplicate(port.port_ref);
        known->ports.push_back(std::move(entry));
      }
      RTC::ExecutionContextList_var contexts = rtc->get_owned_contexts();
      if (contexts->length() > 0 && !CORBA::is_nil(contexts[0])) {
        known->context = orb_.bounded<RTC::ExecutionContext>(contexts[0], kProbeTimeout);
      }
      known->reachable = true;
    } catch (const CORBA::Exception& e) {
      known->retry_at = now + kRetryPeriod;
      spdlog::debug("bridge: {} does not answer ({}); trying again in {} ms", path, rtc::describe(e),
                    kRetryPeriod.count());
    } catch (const std::exception& e) {
      known->retry_at = now + kRetryPeriod;
      spdlog::debug("bridge: {}: {}", path, e.what());
    }
  }

  // 4. Providers that died without unbinding are withdrawn; slow ones are kept and marked, and
  //    the lifecycle state of each is read (an Inactive OpenRTM-aist provider serves nothing).
  for (auto it = known_.begin(); it != known_.end();) {
    const std::string path = it->first;
    Known& known = *(it++)->second;
    if (!known.reachable || known.links.empty()) continue;
    Answer answer = Answer::kAlive;
    std::string why;
    try {
      if (known.probe->_non_existent()) answer = Answer::kGone;
      if (answer == Answer::kAlive && !CORBA::is_nil(known.context)) {
        RTC::RTObject_var self = RTC::RTObject::_unchecked_narrow(known.probe);
        known.state = known.context->get_component_state(self);
        known.state_known = true;
      }
    } catch (const CORBA::SystemException& e) {
      answer = answer_of(e);
      why = rtc::describe(e);
    }
    if (answer == Answer::kGone) {
      forget(path, "stopped answering");
      auto& again = known_[path];  // keep it out of the choice until the binding changes or a retry
      again = std::make_shared<Known>();
      again->ior = bound.count(path) ? bound.at(path).ior : "";
      again->retry_at = Clock::now() + kRetryPeriod;
      continue;
    }
    const bool slow = answer == Answer::kSlow;
    if (slow != known.slow) {
      if (slow) {
        spdlog::warn("bridge: {} did not answer within {} ms ({}); kept, marked slow", path, kProbeTimeout.count(),
                     why);
      } else {
        spdlog::info("bridge: {} answers again", path);
      }
    }
    known.slow = slow;
  }

  // 5. Connect what the rules ask for and is not connected yet.
  for (auto& [path, known] : known_) {
    if (known->reachable && !known->bridged) connect_wanted(path, *known);
  }
}

void RtWatch::connect_wanted(const std::string& path, Known& known) {
  for (const auto& port : known.ports) {
    auto connect = [&](const std::string& link, rtc::PortBase& ours, bool ours_first, const SDOPackage::NVList& extra) {
      if (known.links.count(link)) return;
      RTC::PortService_var ours_ref = ours.reference();
      const std::vector<RTC::PortService_ptr> ports =
          ours_first ? std::vector<RTC::PortService_ptr>{ours_ref.in(), port.ref.in()}
                     : std::vector<RTC::PortService_ptr>{port.ref.in(), ours_ref.in()};
      const std::string name = std::string(kConnectorName) + "." + config_.bridge;
      try {
        rtc::Connection made = rtc::connect_ports(ports, name, extra);
        // A port that still holds a connection to ours whose other half is gone (we could not
        // tell it when it was dropped) refuses a new one, as OpenRTM-aist's ports do: drop
        // that half, then connect again.
        if (made.code == RTC::PRECONDITION_NOT_MET && drop_stale_halves(path, port.ref, port.name, ours) > 0) {
          made = rtc::connect_ports(ports, name, extra);
        }
        if (made.code != RTC::RTC_OK) {
          if (warned_.insert(path + "|" + link).second) {
            spdlog::warn("bridge: connecting {} port {} failed: {}", path, port.name, rtc::return_code_name(made.code));
          }
          return;
        }
        known.links[link] = made.profile.connector_id.in();
        warned_.erase(path + "|" + link);
        spdlog::info("bridge: connected {} port {} ({})", path, port.name, made.profile.connector_id.in());
      } catch (const CORBA::Exception& e) {
        if (warned_.insert(path + "|" + link).second) {
          spdlog::warn("bridge: connecting {} port {}: {}", path, port.name, rtc::describe(e));
        }
      }
    };
    if (port.kind == "CorbaPort" && !port.provided.empty()) {
      bool wanted = false;
      for (const auto& [type, instance] : port.provided) {
        for (const auto& rule : config_.providers) {
          if (glob_match(rule.match, path) && glob_match(rule.interface, type)) wanted = true;
        }
      }
      if (wanted)
        connect(port.name, component_.providers(), true, rtc::nv_from({{"urslink.connector", config_.bridge}}));
    }
    // A data port of the component that one of the bridge's own data ports is configured for.
    auto connect_data = [&](const char* kind, const std::string& match, const std::string& name, rtc::DataPort& ours,
                            const std::string& what, bool ours_first) {
      if (port.kind != kind || port.name != name || !glob_match(match, path)) return;
      if (!rtc::data_type_matches(ours.data_type(), port.data_type)) {
        if (warned_.insert(path + "|type|" + port.name).second) {
          spdlog::error("bridge: {} port {} is of {}, but {} is of {}", path, port.name, port.data_type, what,
                        ours.data_type());
        }
        return;
      }
      connect(port.name + "#" + ours.short_name(), ours, ours_first, rtc::nv_from({}));
    };
    for (std::size_t i = 0; i < config_.in.size(); ++i) {
      const auto& entry = config_.in[i];
      connect_data("DataOutPort", entry.match, entry.port, component_.in_port(i),
                   "data_to_camus[" + std::to_string(i) + "]", false);
    }
    for (std::size_t i = 0; i < config_.out.size(); ++i) {
      const auto& entry = config_.out[i];
      connect_data("DataInPort", entry.match, entry.port, component_.out_port(i),
                   "events_to_rt[" + std::to_string(i) + "]", true);
    }
  }
}

void RtWatch::drop_link(const Known& known, const std::string& link, const std::string& connector_id) {
  // The peer's half first (best effort, bounded): a port that kept it would refuse the next
  // connection to ours (OpenRTM-aist refuses duplicates), and neither its disconnect() (which
  // asks our port first, and ours no longer knows the id) nor a tool could clear it.
  if (const Known::Port* peer = known.port(link); peer != nullptr && !CORBA::is_nil(peer->ref)) {
    try {
      RTC::PortService_var bounded = orb_.bounded<RTC::PortService>(peer->ref, kProbeTimeout);
      bounded->notify_disconnect(connector_id.c_str());
    } catch (const CORBA::Exception& e) {
      spdlog::debug("bridge: port {} did not take back connection {}: {}", peer->name, connector_id, rtc::describe(e));
    }
  }
  component_.port_of_link(link).drop_connection(connector_id);
}

int RtWatch::drop_stale_halves(const std::string& path, RTC::PortService_ptr peer, const std::string& peer_name,
                               rtc::PortBase& ours) {
  std::set<std::string> held;
  for (const auto& profile : ours.connections()) held.insert(profile.connector_id.in());
  RTC::PortService_var ours_ref = ours.reference();
  int dropped = 0;
  try {
    RTC::PortService_var bounded = orb_.bounded<RTC::PortService>(peer, kProfileTimeout);
    RTC::ConnectorProfileList_var profiles = bounded->get_connector_profiles();
    for (CORBA::ULong i = 0; i < profiles->length(); ++i) {
      const RTC::ConnectorProfile& profile = profiles[i];
      if (held.count(profile.connector_id.in())) continue;
      bool lists_ours = false;
      for (CORBA::ULong j = 0; j < profile.ports.length() && !lists_ours; ++j) {
        lists_ours = !CORBA::is_nil(profile.ports[j]) && profile.ports[j]->_is_equivalent(ours_ref);
      }
      if (!lists_ours) continue;
      spdlog::info("bridge: {} port {} still held connection {} to {}, whose other half is gone; dropping it", path,
                   peer_name, profile.connector_id.in(), ours.name());
      bounded->notify_disconnect(profile.connector_id);
      ++dropped;
    }
  } catch (const CORBA::Exception& e) {
    spdlog::debug("bridge: cannot clear stale connections of {} port {}: {}", path, peer_name, rtc::describe(e));
  }
  return dropped;
}

std::vector<core::Offer> RtWatch::provider_offers() {
  std::map<std::string, std::string> paths;  // connector id -> provider path, for connections we made
  std::map<std::string, std::string> by_instance;
  for (const auto& [path, known] : known_) {
    for (const auto& [link, id] : known->links) paths[id] = path;
    if (!known->instance.empty()) by_instance[known->instance] = path;
  }
  std::vector<core::Offer> offers;
  for (const auto& [connector_id, interfaces] : component_.providers().connections()) {
    for (const auto& provided : interfaces) {
      const std::string key = connector_id + "|" + provided.key;
      const std::string path = paths.count(connector_id)               ? paths[connector_id]
                               : by_instance.count(provided.component) ? by_instance[provided.component]
                                                                       : provided.component + ".rtc";
      const google::protobuf::ServiceDescriptor* interface =
          catalog_.find_interface(rt_call::ior_type_id(provided.ior), provided.type_name);
      if (interface == nullptr) {
        if (warned_.insert("iface|" + key).second) {
          spdlog::error(
              "bridge: {} port {} provides {}, whose IDL the bridge does not know (add it under idl:); "
              "not offered to CAMUS",
              path, provided.port, provided.type_name);
        }
        continue;
      }
      const auto slash = path.find('/');
      std::string host = slash == std::string::npos ? "" : path.substr(0, slash);
      if (host.size() > 9 && host.compare(host.size() - 9, 9, ".host_cxt") == 0) host.resize(host.size() - 9);
      core::Offer offer;
      offer.key = key;
      offer.name = path;
      offer.interface_name = provided.type_name;
      offer.fields = {
          {"instance", provided.component}, {"port", provided.port}, {"interface", interface->name()}, {"host", host}};
      offer.properties = {{"rtc.type_name", provided.type_name}};
      if (const auto known = known_.find(path); known != known_.end()) add_health(offer.properties, *known->second);
      offer.revision = provided.ior;
      offer.source = "rtc:" + path + ":" + provided.port;
      offers.push_back(std::move(offer));
    }
  }
  return offers;
}

std::shared_ptr<agent::ServiceAgent> RtWatch::forwarder(const core::Route& route) {
  const auto bar = route.offer.key.find('|');
  const auto connections = component_.providers().connections();
  const auto connection = connections.find(route.offer.key.substr(0, bar));
  if (bar != std::string::npos && connection != connections.end()) {
    for (const auto& provided : connection->second) {
      if (provided.key != route.offer.key.substr(bar + 1)) continue;
      const google::protobuf::ServiceDescriptor* interface =
          catalog_.find_interface(rt_call::ior_type_id(provided.ior), provided.type_name);
      if (interface == nullptr) throw std::runtime_error("the bridge does not know the IDL of " + provided.type_name);
      CORBA::Object_var target = orb_.string_to_object(provided.ior);
      const auto deadline = std::chrono::milliseconds(route.deadline_ms);
      corba_agent::CorbaProxyOptions options{deadline, deadline, {}, orb_.max_calls_per_peer()};
      const auto known = known_.find(route.offer.name);
      if (known != known_.end() && known->second->reachable) {
        options.explain_missing_target = owner_state_check(route.offer.name, known->second->ior);
      }
      return std::make_shared<corba_agent::CorbaProxyAgent>(orb_.orb(), target, *interface, options);
    }
  }
  throw std::runtime_error("the provider's connection " + route.offer.key + " is gone");
}

void RtWatch::add_health(std::map<std::string, std::string>& properties, const Known& known) const {
  properties[core::kHealthProperty] = health_word(known.slow, known.state_known, known.state);
  if (known.state_known) properties["rtc.state"] = rtc::state_name(known.state);
}

std::function<std::string()> RtWatch::owner_state_check(const std::string& path, const std::string& ior) const {
  // Runs on the host's worker threads, after the provider answered OBJECT_NOT_EXIST: OpenRTM-aist
  // deactivates the objects a component provides while it is not Active (docs/bridge.md).
  RTC::RTObject_var owner;
  try {
    CORBA::Object_var object = orb_.string_to_object(ior);
    owner = orb_.bounded<RTC::RTObject>(object, kProbeTimeout);
  } catch (const std::exception&) {
    return {};
  }
  const rtc::Orb* orb = &orb_;
  return [orb, path, owner]() -> std::string {
    try {
      RTC::ExecutionContextList_var contexts = owner->get_owned_contexts();
      if (contexts->length() == 0 || CORBA::is_nil(contexts[0])) return {};
      RTC::ExecutionContext_var context = orb->bounded<RTC::ExecutionContext>(contexts[0], kProbeTimeout);
      const RTC::LifeCycleState state = context->get_component_state(owner);
      switch (state) {
        case RTC::ACTIVE:
          return {};
        case RTC::INACTIVE:
          return "provider component " + path + " is INACTIVE; activate it with `urs rtc act " + path + "`";
        case RTC::ERROR:
          return "provider component " + path + " is in ERROR; reset it with `urs rtc reset " + path +
                 "`, then activate it with `urs rtc act " + path + "`";
        default:
          return "provider component " + path + " is not initialized (CREATED)";
      }
    } catch (const CORBA::Exception&) {
      return {};
    }
  };
}

std::vector<core::ComponentState> RtWatch::component_states() const {
  std::vector<core::ComponentState> states;
  for (const auto& [path, known] : known_) {
    if (known->bridged) continue;  // the bridge's own RTCs stand for other spaces' services
    core::ComponentState state;
    state.name = path;
    state.kind = "rtc";
    state.type_name = known->type_name;
    const auto slash = path.rfind('/');
    state.host = slash == std::string::npos ? "" : path.substr(0, slash);
    state.state = "Unreachable";
    if (known->reachable) {
      try {
        RTC::RTObject_var rtc = RTC::RTObject::_unchecked_narrow(known->probe);
        state.state = rtc::state_name(rtc::component_state(rtc));
      } catch (const CORBA::Exception&) {
      }
    }
    states.push_back(std::move(state));
  }
  return states;
}

}  // namespace urs::bridge
