#include "urs/bridge/bridge.hpp"

#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/struct.pb.h>
#include <omniORB4/minorCode.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>

#include "camus.pb.h"
#include "urs/agent/agent.hpp"
#include "urs/agent/camus.hpp"
#include "urs/agent/client_sink.hpp"
#include "urs/bridge/camus_forwarding_agent.hpp"
#include "urs/bridge/dds_link.hpp"
#include "urs/bridge/provider_port.hpp"
#include "urs/bridge/space_state.hpp"
#include "urs/corba_agent/agent_component.hpp"
#include "urs/corba_agent/corba_proxy.hpp"
#include "urs/planet/call_adapter.hpp"
#include "urs/rtc/component.hpp"
#include "urs/rtc/data_port.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/tools.hpp"
#include "urs/schema/json.hpp"
#include "urs/rtc/execution_context.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::bridge {

namespace gp = google::protobuf;
using Clock = std::chrono::steady_clock;

namespace {

constexpr auto kCamusTimeout = std::chrono::milliseconds(2000);  // registry calls of one poll
constexpr auto kProbeTimeout = std::chrono::milliseconds(500);   // liveness probe of a provider
constexpr auto kProfileTimeout = std::chrono::milliseconds(2000);  // reading a component's profile
constexpr auto kRetryPeriod = std::chrono::milliseconds(2000);   // a component that did not answer
constexpr const char* kOrigin = "urslink.origin";
constexpr const char* kHealth = "urslink.health";  // of an RT provider: "ok", "slow", "inactive", ...
constexpr const char* kConnectorName = "urs-bridge";

std::string sanitize(const std::string& text) {
  std::string out = text;
  for (char& c : out) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') c = '_';
  }
  return out;
}

std::string nv_text(const SDOPackage::NVList& list, const char* name) {
  for (CORBA::ULong i = 0; i < list.length(); ++i) {
    if (std::string(list[i].name.in()) != name) continue;
    const char* value = nullptr;
    if (list[i].value >>= value) return value;
  }
  return "";
}

SDOPackage::NVList properties(std::initializer_list<std::pair<const char*, std::string>> entries) {
  SDOPackage::NVList list;
  list.length(static_cast<CORBA::ULong>(entries.size()));
  CORBA::ULong i = 0;
  for (const auto& [name, value] : entries) {
    list[i].name = name;
    list[i].value <<= value.c_str();
    ++i;
  }
  return list;
}

// How a component answered a probe. Slowness is not death: only an object that does not exist,
// or a process that refuses the connection, is gone; a call that timed out or a connection cut
// mid-call says nothing yet (the next probe will).
enum class Liveness { kAlive, kSlow, kGone };

Liveness liveness_of(const CORBA::SystemException& e) {
  if (dynamic_cast<const CORBA::TIMEOUT*>(&e) != nullptr || dynamic_cast<const CORBA::COMM_FAILURE*>(&e) != nullptr) {
    return Liveness::kSlow;
  }
  if (dynamic_cast<const CORBA::TRANSIENT*>(&e) != nullptr) {
    return e.minor() == omni::TRANSIENT_CallTimedout ? Liveness::kSlow : Liveness::kGone;
  }
  return Liveness::kGone;  // OBJECT_NOT_EXIST, INV_OBJREF, ...
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

// ---- the RT-Component ----------------------------------------------------------------------

class Bridge::Component : public rtc::Component {
 public:
  Component(Bridge& bridge)
      : rtc::Component({"Bridge", "URSLink bridge between RT-Middleware and CAMUS", "1.0.0", "URSLink", "bridge"}),
        bridge_(bridge),
        providers_("providers") {
    const auto& config = bridge.config_;
    for (std::size_t i = 0; i < config.data_to_camus.size(); ++i) {
      const gp::Descriptor* type = bridge.catalog_.find_message(config.data_to_camus[i].type);
      in_ports_.push_back(std::make_unique<corba_agent::RawInPort>(
          "in" + std::to_string(i), *type, [&bridge, i](const gp::Message& value) { bridge.on_data(i, value); }));
    }
    for (std::size_t i = 0; i < config.events_to_rt.size(); ++i) {
      const gp::Descriptor* type = bridge.catalog_.find_message(config.events_to_rt[i].type);
      out_ports_.push_back(std::make_unique<corba_agent::RawOutPort>("out" + std::to_string(i), *type));
    }
  }

  ProviderPort& providers() { return providers_; }
  corba_agent::RawInPort& in_port(std::size_t i) { return *in_ports_.at(i); }
  corba_agent::RawOutPort& out_port(std::size_t i) { return *out_ports_.at(i); }

 protected:
  RTC::ReturnCode_t handle_initialize() override {
    add_port(providers_);
    for (auto& port : in_ports_) add_port(*port);
    for (auto& port : out_ports_) add_port(*port);
    declare_parameter("planet_peer", bridge_.config_.name);
    return RTC::RTC_OK;
  }
  RTC::ReturnCode_t handle_activated(RTC::ExecutionContextHandle_t) override {
    bridge_.request_active(true);
    return RTC::RTC_OK;
  }
  RTC::ReturnCode_t handle_deactivated(RTC::ExecutionContextHandle_t) override {
    bridge_.request_active(false);
    return RTC::RTC_OK;
  }
  RTC::ReturnCode_t handle_finalize() override {
    bridge_.request_active(false);
    return RTC::RTC_OK;
  }

 private:
  Bridge& bridge_;
  ProviderPort providers_;
  std::vector<std::unique_ptr<corba_agent::RawInPort>> in_ports_;
  std::vector<std::unique_ptr<corba_agent::RawOutPort>> out_ports_;
};

// ---- one activation: the Planet session and what it carries ------------------------------------

// Where proxies' events go when the bridge has no CAMUS server.
class NoEvents : public agent::EventSink {
 public:
  call::Reply publish(const std::string& topic, const gp::Message&) override {
    return call::Reply::error(call::Status::UNAVAILABLE, "no CAMUS server: event on " + topic + " not published");
  }
};

class Bridge::Session {
 public:
  // Without Planet options (a space with no CAMUS server) the session has no client.
  Session(const BridgeConfig& config, const std::optional<planet::ClientOptions>& options)
      : client(options ? std::make_unique<planet::Client>(*options) : nullptr),
        sink(client ? std::unique_ptr<agent::EventSink>(std::make_unique<agent::ClientEventSink>(*client))
                    : std::make_unique<NoEvents>()),
        host(config.workers, *sink, &factory_with_delegation()) {}

  std::unique_ptr<planet::Client> client;
  std::unique_ptr<agent::EventSink> sink;

 private:
  gp::DynamicMessageFactory factory_;
  gp::DynamicMessageFactory& factory_with_delegation() {
    factory_.SetDelegateToGeneratedFactory(true);
    return factory_;
  }

 public:
  agent::AgentHost host;      // the proxies of RT providers
  schema::SchemaPool remote;  // interfaces of CAMUS services, from the registry

  std::map<std::string, std::string> exports;  // export key ("<connector id>|<key>") -> CAMUS name
  std::map<std::string, std::string> export_paths;   // CAMUS name of an RT provider -> its naming path
  std::map<std::string, std::string> export_health;  // CAMUS name -> urslink.health last registered
  struct Import {
    rtc::Component* component;
    std::string path;
  };
  std::map<std::string, Import> imports;                    // by CAMUS service
  std::map<std::string, Clock::time_point> import_retry;   // services whose import failed
  std::vector<uint64_t> subscriptions;
  // Writes events to RT InPorts one at a time, in order, off the Planet client's thread, so a
  // slow InPort (flush: each write waits for the peer) never holds up the session.
  agent::WorkerPool event_writer{1};

  // ---- between spaces (DDS) ----
  std::map<std::string, camus::ServiceInfo> camus_native;  // this space's own CAMUS services, last listed
  // A descriptor set is some kB; the services of one interface share theirs.
  struct ByContent {
    bool operator()(const std::shared_ptr<const std::string>& a, const std::shared_ptr<const std::string>& b) const {
      return *a < *b;
    }
  };
  std::set<std::shared_ptr<const std::string>, ByContent> descriptions;     // each distinct descriptor set
  std::map<std::string, std::shared_ptr<const std::string>> described;  // CAMUS service -> its descriptor set
  std::map<std::string, ServiceEntry> announced;            // what this space offers the others
  Clock::time_point announced_at;
  std::mutex served_mutex;                                  // read by DDS threads
  std::map<std::string, bool> served;                       // exported name -> proxied on `host` (else CAMUS)
  struct Remote {
    std::string interface_name;
    std::string descriptor_set;
    std::string camus_name;                // "" if not offered on CAMUS
    rtc::Component* component = nullptr;  // nullptr if not in the naming service
    std::string path;
  };
  std::map<std::string, Remote> remotes;  // by "<space>/<service>"
  std::map<std::string, std::unique_ptr<schema::SchemaPool>> space_pools;
  std::vector<std::unique_ptr<schema::SchemaPool>> extra_pools;  // descriptions that clash within a space
  Clock::time_point catalog_read_at;
  std::unique_ptr<DdsLink> dds;  // near last: destroyed early, so no DDS thread outlives what it uses
  std::unique_ptr<SpaceState> state;  // on `dds`: destroyed before it
};

// ---- a component found in the naming service -------------------------------------------------

struct Bridge::Known {
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
  CORBA::Object_var probe;             // the component, calls bounded by kProbeTimeout
  RTC::ExecutionContext_var context;   // its first owned context, bounded the same; nil if none
  bool slow = false;                   // the last probe timed out (it is kept, not withdrawn)
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

// ---- the bridge ------------------------------------------------------------------------------

Bridge::Bridge(rtc::Orb& orb, rtc::NamingClient* naming, rtc::Manager* manager, const InterfaceCatalog& catalog,
               BridgeConfig config, std::optional<planet::ClientOptions> planet)
    : orb_(orb), naming_(naming), manager_(manager), catalog_(catalog), config_(std::move(config)),
      planet_(std::move(planet)),
      store_(config_.data_dir.empty() || manager_ == nullptr
                 ? std::string()
                 : config_.data_dir + "/connections-" + sanitize(config_.name) + ".yaml") {
  if ((naming_ == nullptr) != (manager_ == nullptr)) throw std::logic_error("bridge: naming client without manager");
  if (planet_) {
    planet_->peer_name = config_.name;
    planet_->role = planet::SAM;
  }
  std::vector<std::string> errors;
  if (!manager_ && !config_.data_to_camus.empty()) errors.push_back("data_to_camus: needs a naming service (--naming)");
  if (!manager_ && !config_.events_to_rt.empty()) errors.push_back("events_to_rt: needs a naming service (--naming)");
  if (!planet_ && !config_.events_to_rt.empty()) errors.push_back("events_to_rt: needs a CAMUS server (--server)");
  if (!planet_ && !config_.data_to_camus.empty()) errors.push_back("data_to_camus: needs a CAMUS server (--server)");
  auto check_type = [&](const std::string& type, const std::string& where) {
    const gp::Descriptor* found = catalog_.find_message(type);
    if (found == nullptr) {
      errors.push_back(where + ".type: no message type " + type + " is known (add its IDL under idl:)");
    } else if (schema::repository_id(*found).empty()) {
      errors.push_back(where + ".type: " + type + " is not an IDL struct, exception or union");
    }
  };
  for (std::size_t i = 0; i < config_.data_to_camus.size(); ++i) {
    check_type(config_.data_to_camus[i].type, "data_to_camus[" + std::to_string(i) + "]");
  }
  for (std::size_t i = 0; i < config_.events_to_rt.size(); ++i) {
    check_type(config_.events_to_rt[i].type, "events_to_rt[" + std::to_string(i) + "]");
  }
  util::throw_if_errors(errors, "bridge configuration");
}

Bridge::~Bridge() { shutdown(); }

rtc::Component* Bridge::start() {
  if (!manager_) {  // no RT side: no RTC, so no lifecycle to follow; active from the start
    thread_ = std::thread([this] { run(); });
    request_active(true);
    return nullptr;
  }
  rtc::ComponentSpec spec;
  spec.type = "Bridge";
  spec.instance_name = config_.instance;
  spec.properties = {{"urslink.bridge", config_.name}};
  rtc::Component& created = manager_->create(spec, [this](const YAML::Node&, const rtc::ComponentEnv&) {
    auto component = std::make_unique<Component>(*this);
    component_ = component.get();
    return component;
  });
  own_path_ = manager_->naming_path(created);
  thread_ = std::thread([this] { run(); });
  if (config_.activate) {
    RTC::RTObject_var self = created.reference();
    RTC::ExecutionContextService_var context = created.execution_context().reference();
    const RTC::ReturnCode_t result = context->activate_component(self);
    if (result != RTC::RTC_OK) {
      throw std::runtime_error(own_path_ + ": activation returned " + rtc::return_code_name(result));
    }
  }
  return &created;
}

void Bridge::shutdown() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && !thread_.joinable()) return;
    stopping_ = true;
    want_active_ = false;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

BridgeStatus Bridge::status() const {
  std::lock_guard lock(mutex_);
  BridgeStatus status;
  status.active = session_ != nullptr;
  if (session_) {
    for (const auto& [key, name] : session_->exports) status.exported.push_back(name);
    status.health = session_->export_health;
    for (const auto& [service, import] : session_->imports) status.imported.push_back(import.path);
    for (const auto& [key, remote] : session_->remotes) status.remote.push_back(key);
  }
  return status;
}

void Bridge::request_active(bool active) {
  {
    std::lock_guard lock(mutex_);
    want_active_ = active;
  }
  wake_.notify_all();
}

void Bridge::run() {
  auto next_rt = Clock::now();
  auto next_camus = Clock::now();
  while (true) {
    bool want = false;
    {
      std::unique_lock lock(mutex_);
      auto changed = [&] { return stopping_ || want_active_ != (session_ != nullptr); };
      if (session_) {
        const auto next = std::min(next_rt, next_camus);
        wake_.wait_until(lock, next, [&] { return changed() || remote_pending_.load() || Clock::now() >= next; });
      } else {
        wake_.wait(lock, changed);
      }
      if (stopping_ && !session_) return;
      want = want_active_ && !stopping_;
    }
    try {
      if (want && !session_) {
        open_session();
        next_rt = next_camus = Clock::now();
      } else if (!want && session_) {
        close_session();
        continue;
      }
      if (!session_) continue;
      const auto now = Clock::now();
      if (now >= next_rt) {
        poll_rt();
        next_rt = Clock::now() + config_.rt_poll;
      }
      if (now >= next_camus) {
        poll_camus();
        next_camus = Clock::now() + config_.camus_poll;
      }
      poll_dds();
    } catch (const std::exception& e) {
      spdlog::error("bridge: {}", e.what());
      next_rt = next_camus = Clock::now() + config_.rt_poll;
    }
  }
}

void Bridge::open_session() {
  auto session = std::make_shared<Session>(config_, planet_);
  if (session->client) open_planet(*session);
  session->host.start();
  if (config_.dds.enabled) {
    DdsOptions options;
    options.domain = config_.dds.domain;
    options.space = config_.space;
    options.bridge = config_.name;
    options.lease = config_.dds.lease;
    options.participant_lease = config_.dds.participant_lease;
    options.udp_only = config_.dds.udp_only;
    options.socket_buffer_bytes = config_.dds.socket_buffer_bytes;
    options.initial_peers = config_.dds.initial_peers;
    options.discovery_listen = config_.dds.discovery_listen;
    options.discovery_server_id = config_.dds.discovery_server_id;
    options.discovery_servers = config_.dds.discovery_servers;
    Session* s = session.get();
    try {
      session->dds = std::make_unique<DdsLink>(
          options,
          [this] {
            remote_pending_ = true;
            wake_.notify_all();
          },
          [this, s](call::Request request, call::Responder responder) {
            serve_remote(*s, std::move(request), std::move(responder));
          });
      std::string discovery;
      if (!options.discovery_listen.empty()) discovery = ", discovery server at " + options.discovery_listen;
      for (const auto& server : options.discovery_servers) discovery += ", discovery server " + server;
      spdlog::info("bridge {}: space {} joined DDS domain {}{}{}", config_.name, config_.space, config_.dds.domain,
                   config_.dds.udp_only ? " (UDP only)" : "", discovery);
    } catch (const std::exception& e) {
      spdlog::error("bridge {}: no link to other spaces: {}", config_.name, e.what());
    }
  }
  if (session->dds) {
    try {
      session->state = std::make_unique<SpaceState>(config_, *session->dds, session->client.get());
    } catch (const std::exception& e) {
      spdlog::error("bridge {}: the spaces share no state: {}", config_.name, e.what());
    }
  }
  {
    std::lock_guard lock(mutex_);
    session_ = session;
  }
  load_connections();
  if (planet_) {
    spdlog::info("bridge {}: active (CAMUS server {}:{})", config_.name, planet_->host, planet_->port);
  } else {
    spdlog::info("bridge {}: active (no CAMUS server)", config_.name);
  }
}

void Bridge::open_planet(Session& s) {
  Session* session = &s;
  agent::serve_requests(*session->client, session->host);
  session->client->on_connected([this](const planet::Welcome& welcome) {
    spdlog::info("bridge {}: connected to the CAMUS server of space {}", config_.name, welcome.space());
  });
  session->client->on_disconnected([this](const std::string& reason) {
    spdlog::warn("bridge {}: lost the CAMUS server: {}; reconnecting", config_.name, reason);
  });
  for (std::size_t i = 0; i < config_.events_to_rt.size(); ++i) {
    const EventsToRt& entry = config_.events_to_rt[i];
    const gp::Descriptor* type = catalog_.find_message(entry.type);
    auto* port = &component_->out_port(i);
    auto factory = std::make_shared<gp::DynamicMessageFactory>();
    factory->SetDelegateToGeneratedFactory(true);
    session->subscriptions.push_back(session->client->subscribe(entry.topic, [session, type, port, factory](
                                                                              const planet::Event& event) {
      if (event.content_type() != type->full_name()) {
        spdlog::debug("bridge: event on {} is a {}, not {}; not sent to {}", event.topic(), event.content_type(),
                      type->full_name(), port->name());
        return;
      }
      std::shared_ptr<gp::Message> value(factory->GetPrototype(type)->New());
      if (!value->ParseFromString(event.payload())) {
        spdlog::warn("bridge: event {} on {} is not a valid {}; not sent to {}", event.seq(), event.topic(),
                     type->full_name(), port->name());
        return;
      }
      session->event_writer.post([port, value, seq = event.seq(), topic = event.topic()](bool cancelled) {
        if (cancelled) {
          spdlog::warn("bridge: deactivated before event {} on {} went out through {}", seq, topic, port->name());
          return;
        }
        try {
          const auto result = port->write(*value);
          if (result.refused > 0) {
            spdlog::warn("bridge: event {} on {}: {} InPort(s) of {} refused it", seq, topic, result.refused,
                         port->name());
          }
        } catch (const std::exception& e) {
          spdlog::warn("bridge: event {} on {} cannot go out through {}: {}", seq, topic, port->name(), e.what());
        }
      });
    }));
  }
  session->client->start();
}

void Bridge::close_session() {
  std::shared_ptr<Session> session;
  {
    std::lock_guard lock(mutex_);
    session.swap(session_);
  }
  session->state.reset();
  session->dds.reset();  // the others drop this space's services; no more calls arrive
  for (auto& [key, remote] : session->remotes) {
    if (remote.component) manager_->destroy(*remote.component);
  }
  for (auto& [service, import] : session->imports) {
    spdlog::info("bridge: withdrawing {} (stood for CAMUS service {})", import.path, service);
    manager_->destroy(*import.component);
  }
  if (session->client) {
    for (const auto& [key, name] : session->exports) session->client->unregister_service(name);
    for (uint64_t id : session->subscriptions) session->client->unsubscribe(id);
  }
  session->host.stop();
  if (session->client) session->client->stop();
  session->event_writer.stop();
  spdlog::info("bridge {}: inactive; {} export(s) and {} import(s) withdrawn", config_.name, session->exports.size(),
               session->imports.size());
}

// ---- RT side ---------------------------------------------------------------------------------

void Bridge::poll_rt() {
  if (!manager_) return;
  // 1. What the naming service holds now (only components some rule may concern).
  auto concerned = [this](const std::string& path) {
    if (path == own_path_) return false;
    if (session_->state && config_.dds.state.components) return true;  // every RTC's state is shared
    for (const auto& rule : config_.providers) {
      if (glob_match(rule.match, path)) return true;
    }
    for (const auto& entry : config_.data_to_camus) {
      if (glob_match(entry.match, path)) return true;
    }
    for (const auto& entry : config_.events_to_rt) {
      if (glob_match(entry.match, path)) return true;
    }
    return false;
  };
  std::map<std::string, std::string> bound;  // path -> IOR
  try {
    for (const auto& entry : naming_->list_objects("")) {
      if (entry.kind != "rtc" || !concerned(entry.path)) continue;
      CORBA::Object_var object = naming_->try_resolve(entry.path);
      if (!CORBA::is_nil(object)) bound[entry.path] = orb_.object_to_string(object);
    }
  } catch (const std::exception& e) {
    if (warned_.insert("naming").second) spdlog::warn("bridge: naming service {}: {}", naming_->address(), e.what());
    return;
  }
  warned_.erase("naming");

  auto forget = [this](const std::string& path, const char* why) {
    auto it = known_.find(path);
    if (it == known_.end()) return;
    for (const auto& [link, connector_id] : it->second->links) {
      spdlog::info("bridge: {} {}: dropping connection {} of its port {}", path, why, connector_id, link);
      drop_link(*it->second, link, connector_id);
    }
    known_.erase(it);
  };

  // 2. Components gone or replaced.
  for (auto it = known_.begin(); it != known_.end();) {
    const auto now_bound = bound.find(it->first);
    const bool gone = now_bound == bound.end() || now_bound->second != it->second->ior;
    const std::string path = (it++)->first;
    if (gone) forget(path, now_bound == bound.end() ? "unbound" : "rebound to another object");
  }

  // 3. New components: read their ports.
  const auto now = Clock::now();
  for (const auto& [path, ior] : bound) {
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
      known->bridged = !nv_text(profile->properties, kOrigin).empty() || !nv_text(profile->properties, "urslink.bridge").empty();
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
      spdlog::debug("bridge: {} does not answer ({}); trying again in {} ms", path, rtc::describe(e), kRetryPeriod.count());
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
    Liveness answer = Liveness::kAlive;
    std::string why;
    try {
      if (known.probe->_non_existent()) answer = Liveness::kGone;
      if (answer == Liveness::kAlive && !CORBA::is_nil(known.context)) {
        RTC::RTObject_var self = RTC::RTObject::_unchecked_narrow(known.probe);
        known.state = known.context->get_component_state(self);
        known.state_known = true;
      }
    } catch (const CORBA::SystemException& e) {
      answer = liveness_of(e);
      why = rtc::describe(e);
    }
    if (answer == Liveness::kGone) {
      forget(path, "stopped answering");
      auto& again = known_[path];  // keep it out of the choice until the binding changes or a retry
      again = std::make_shared<Known>();
      again->ior = bound.count(path) ? bound[path] : "";
      again->retry_at = Clock::now() + kRetryPeriod;
      continue;
    }
    const bool slow = answer == Liveness::kSlow;
    if (slow != known.slow) {
      if (slow) {
        spdlog::warn("bridge: {} did not answer within {} ms ({}); kept, marked slow", path, kProbeTimeout.count(), why);
      } else {
        spdlog::info("bridge: {} answers again", path);
      }
    }
    known.slow = slow;
  }

  // 5. Connect what the rules ask for and is not connected yet.
  for (auto& [path, known_ptr] : known_) {
    Known& known = *known_ptr;
    if (!known.reachable || known.bridged) continue;
    for (const auto& port : known.ports) {
      auto connect = [&](const std::string& link, rtc::PortBase& ours, bool ours_first,
                         const SDOPackage::NVList& extra) {
        if (known.links.count(link)) return;
        RTC::PortService_var ours_ref = ours.reference();
        const std::vector<RTC::PortService_ptr> ports =
            ours_first ? std::vector<RTC::PortService_ptr>{ours_ref.in(), port.ref.in()}
                       : std::vector<RTC::PortService_ptr>{port.ref.in(), ours_ref.in()};
        const std::string name = std::string(kConnectorName) + "." + config_.name;
        try {
          rtc::Connection made = rtc::connect_ports(ports, name, extra);
          // A port that still holds a connection to ours whose other half is gone (we could not
          // tell it when it was dropped) refuses a new one, as OpenRTM-aist's ports do: drop
          // that half, then connect again.
          if (made.code == RTC::PRECONDITION_NOT_MET &&
              drop_stale_halves(path, port.ref, port.name, ours) > 0) {
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
        if (wanted) connect(port.name, component_->providers(), true, properties({{"urslink.connector", config_.name}}));
      }
      // A data port of the component that one of the bridge's own data ports is configured for.
      auto connect_data = [&](const char* kind, const std::string& match, const std::string& name,
                              rtc::DataPort& ours, const std::string& what, bool ours_first,
                              const SDOPackage::NVList& extra) {
        if (port.kind != kind || port.name != name || !glob_match(match, path)) return;
        if (!rtc::data_type_matches(ours.data_type(), port.data_type)) {
          if (warned_.insert(path + "|type|" + port.name).second) {
            spdlog::error("bridge: {} port {} is of {}, but {} is of {}", path, port.name, port.data_type, what,
                          ours.data_type());
          }
          return;
        }
        connect(port.name + "#" + ours.short_name(), ours, ours_first, extra);
      };
      for (std::size_t i = 0; i < config_.data_to_camus.size(); ++i) {
        const auto& entry = config_.data_to_camus[i];
        connect_data("DataOutPort", entry.match, entry.port, component_->in_port(i),
                     "data_to_camus[" + std::to_string(i) + "]", false, properties({}));
      }
      for (std::size_t i = 0; i < config_.events_to_rt.size(); ++i) {
        const auto& entry = config_.events_to_rt[i];
        connect_data("DataInPort", entry.match, entry.port, component_->out_port(i),
                     "events_to_rt[" + std::to_string(i) + "]", true,
                     properties({}));
      }
    }
  }

  reconcile_exports();
  restore_connections(*session_);
  save_connections(*session_);
  sync_dds_exports(*session_);
  if (session_->state && session_->state->rtc_states_due()) share_rtc_states();
}

rtc::PortBase& Bridge::our_port(const std::string& link) {
  const auto hash = link.find('#');
  if (hash == std::string::npos) return component_->providers();
  const std::string ours = link.substr(hash + 1);
  for (std::size_t i = 0; i < config_.data_to_camus.size(); ++i) {
    if (component_->in_port(i).short_name() == ours) return component_->in_port(i);
  }
  for (std::size_t i = 0; i < config_.events_to_rt.size(); ++i) {
    if (component_->out_port(i).short_name() == ours) return component_->out_port(i);
  }
  throw std::logic_error("bridge: no port " + ours + " of its own");
}

void Bridge::drop_link(const Known& known, const std::string& link, const std::string& connector_id) {
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
  our_port(link).drop_connection(connector_id);
}

int Bridge::drop_stale_halves(const std::string& path, RTC::PortService_ptr peer, const std::string& peer_name,
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

// ---- restarts -------------------------------------------------------------------------------

rtc::Component* Bridge::our_rtc(Session& session, const std::string& key) const {
  if (key == "bridge") return component_;
  if (key.rfind("camus:", 0) == 0) {
    const auto it = session.imports.find(key.substr(6));
    return it == session.imports.end() ? nullptr : it->second.component;
  }
  if (key.rfind("dds:", 0) == 0) {
    const auto it = session.remotes.find(key.substr(4));
    return it == session.remotes.end() ? nullptr : it->second.component;
  }
  return nullptr;
}

void Bridge::load_connections() {
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

void Bridge::restore_connections(Session& session) {
  const auto now = Clock::now();
  for (auto it = restores_.begin(); it != restores_.end();) {
    const SavedConnection& saved = it->saved;
    rtc::Component* component = our_rtc(session, saved.rtc);
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
        try {
          gone = gone || peers.back()->_non_existent();
        } catch (const CORBA::SystemException& e) {
          gone = gone || liveness_of(e) == Liveness::kGone;
        }
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
        warned_.erase("restore|" + saved.id);
        it = restores_.erase(it);
        continue;
      }
      if (warned_.insert("restore|" + saved.id).second) {
        spdlog::warn("bridge: restoring connection {} of {}: {}; trying again every {} ms", saved.id, where,
                     rtc::return_code_name(made.code), kRetryPeriod.count());
      }
    } catch (const std::exception& e) {
      if (warned_.insert("restore|" + saved.id).second) {
        spdlog::warn("bridge: restoring connection {} of {}: {}", saved.id, where, e.what());
      }
    } catch (const CORBA::Exception& e) {
      if (warned_.insert("restore|" + saved.id).second) {
        spdlog::warn("bridge: restoring connection {} of {}: {}", saved.id, where, rtc::describe(e));
      }
    }
    it->retry_at = now + kRetryPeriod;
    ++it;
  }
}

void Bridge::save_connections(Session& session) {
  if (store_.path().empty()) return;
  std::vector<std::pair<std::string, rtc::Component*>> rtcs{{"bridge", component_}};
  for (const auto& [service, import] : session.imports) rtcs.emplace_back("camus:" + service, import.component);
  for (const auto& [key, remote] : session.remotes) {
    if (remote.component) rtcs.emplace_back("dds:" + key, remote.component);
  }
  const std::string ours_name = std::string(kConnectorName) + "." + config_.name;
  const auto ior_of = [this](CORBA::Object_ptr object) { return orb_.object_to_string(object); };
  std::vector<SavedConnection> held;
  for (const auto& [key, component] : rtcs) {
    for (rtc::PortBase* port : component->ports()) {
      RTC::PortService_var ref = port->reference();
      for (const auto& profile : port->connections()) {
        SavedConnection saved;
        if (describe_connection(profile, ref, key, port->short_name(), ours_name == profile.name.in(), ior_of, saved)) {
          held.push_back(std::move(saved));
        }
      }
    }
  }
  for (const auto& restore : restores_) held.push_back(restore.saved);  // kept until made again
  store_.save(held);
}

void Bridge::share_rtc_states() {
  std::vector<ComponentState> states;
  for (const auto& [path, known] : known_) {
    if (known->bridged) continue;  // the bridge's own RTCs stand for other spaces' services
    ComponentState state;
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
  session_->state->rtc_states(states);
}

void Bridge::reconcile_exports() {
  auto session = session_;
  std::map<std::string, std::string> paths;  // connector id -> provider path, for connections we made
  std::map<std::string, std::string> by_instance;
  for (const auto& [path, known] : known_) {
    for (const auto& [link, id] : known->links) paths[id] = path;
    if (!known->instance.empty()) by_instance[known->instance] = path;
  }
  std::set<std::string> current;
  for (const auto& [connector_id, interfaces] : component_->providers().connections()) {
    for (const auto& provided : interfaces) {
      const std::string key = connector_id + "|" + provided.key;
      current.insert(key);
      if (session->exports.count(key)) continue;
      std::string path = paths.count(connector_id) ? paths[connector_id]
                         : by_instance.count(provided.component) ? by_instance[provided.component]
                                                                  : provided.component + ".rtc";
      const gp::ServiceDescriptor* interface = catalog_.find_interface(ior_type_id(provided.ior), provided.type_name);
      if (interface == nullptr) {
        if (warned_.insert("iface|" + key).second) {
          spdlog::error("bridge: {} port {} provides {}, whose IDL the bridge does not know (add it under idl:); "
                        "not offered to CAMUS", path, provided.port, provided.type_name);
        }
        continue;
      }
      ProviderRule rule;
      for (const auto& candidate : config_.providers) {
        if (glob_match(candidate.match, path) && glob_match(candidate.interface, provided.type_name)) {
          rule = candidate;
          break;
        }
      }
      const auto slash = path.find('/');
      std::string host = slash == std::string::npos ? "" : path.substr(0, slash);
      if (host.size() > 9 && host.compare(host.size() - 9, 9, ".host_cxt") == 0) host.resize(host.size() - 9);
      const std::string name = expand(rule.name, {{"instance", provided.component},
                                                   {"port", provided.port},
                                                   {"interface", interface->name()},
                                                   {"host", host}});
      try {
        CORBA::Object_var target = orb_.string_to_object(provided.ior);
        corba_agent::CorbaProxyOptions options{std::chrono::milliseconds(rule.deadline_ms),
                                               std::chrono::milliseconds(rule.deadline_ms), {}};
        const auto known = known_.find(path);
        if (known != known_.end() && known->second->reachable) {
          options.explain_missing_target = owner_state_check(path, known->second->ior);
        }
        auto proxy = std::make_shared<corba_agent::CorbaProxyAgent>(orb_.orb(), target, *interface, options);
        agent::HostedService hosted{name, proxy,
                                    {{kOrigin, "rtc:" + path + ":" + provided.port},
                                     {"urslink.bridge", config_.name},
                                     {"rtc.type_name", provided.type_name}},
                                    rule.deadline_ms};
        if (known != known_.end()) add_health(hosted.properties, *known->second);
        session->host.add(hosted);
        if (session->client) session->client->register_service(agent::registration(hosted), [name, path](planet::CallResult result) {
          if (result.ok()) {
            spdlog::info("bridge: {} offered to CAMUS as {}", path, name);
          } else {
            spdlog::error("bridge: offering {} as {} failed: {}: {}", path, name, planet::status_name(result.status),
                          result.message);
          }
        });
        std::lock_guard lock(mutex_);
        session->exports[key] = name;
        session->export_paths[name] = path;
        session->export_health[name] = hosted.properties.count(kHealth) ? hosted.properties.at(kHealth) : "";
      } catch (const std::exception& e) {
        if (warned_.insert("export|" + key).second) spdlog::error("bridge: cannot offer {} as {}: {}", path, name, e.what());
      }
    }
  }
  for (auto it = session->exports.begin(); it != session->exports.end();) {
    if (current.count(it->first)) {
      ++it;
      continue;
    }
    spdlog::info("bridge: withdrawing {} (its provider is disconnected)", it->second);
    if (session->client) session->client->unregister_service(it->second);
    session->host.remove(it->second);
    std::lock_guard lock(mutex_);
    session->export_paths.erase(it->second);
    session->export_health.erase(it->second);
    it = session->exports.erase(it);
  }
  update_health(*session);
}

void Bridge::add_health(std::map<std::string, std::string>& properties, const Known& known) const {
  properties[kHealth] = health_word(known.slow, known.state_known, known.state);
  if (known.state_known) properties["rtc.state"] = rtc::state_name(known.state);
}

void Bridge::update_health(Session& session) {
  for (const auto& [name, path] : session.export_paths) {
    const auto known = known_.find(path);
    const agent::HostedService* hosted = session.host.find(name);
    if (known == known_.end() || hosted == nullptr) continue;
    agent::HostedService updated = *hosted;
    add_health(updated.properties, *known->second);
    const std::string& health = updated.properties[kHealth];
    {
      std::lock_guard lock(mutex_);  // status() reads it
      std::string& registered = session.export_health[name];
      if (health == registered) continue;
      registered = health;
    }
    spdlog::info("bridge: {} is {} ({})", name, health, path);
    // Registering again under the same name replaces the registry's entry (and what the client
    // re-registers after a reconnect).
    if (session.client) session.client->register_service(agent::registration(updated));
  }
}

std::function<std::string()> Bridge::owner_state_check(const std::string& path, const std::string& ior) const {
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
        case RTC::ACTIVE: return {};
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

void Bridge::on_data(std::size_t entry, const gp::Message& value) {
  std::shared_ptr<Session> session;
  {
    std::lock_guard lock(mutex_);
    session = session_;
  }
  const DataToCamus& config = config_.data_to_camus[entry];
  if (!session || !session->client) {
    spdlog::debug("bridge: inactive; a value for {} is not forwarded", config.topic);
    return;
  }
  const auto published = session->client->publish(config.topic, value.SerializeAsString(), value.GetTypeName());
  if (!published.ok()) {
    spdlog::warn("bridge: value for {} not published: {}", config.topic, published.message);
  }
  if (config.context.empty()) return;
  std::string json;
  camus::ContextSetRequest request;
  request.set_key(config.context);
  request.set_source(config_.name);
  std::string error = schema::message_to_json(value, json);
  if (error.empty()) error = schema::json_to_message(json, *request.mutable_value());
  if (!error.empty()) {
    spdlog::warn("bridge: value for context {} cannot be converted: {}", config.context, error);
    return;
  }
  session->client->call_async("camus.context", "Set", request.SerializeAsString(), kCamusTimeout,
                             [key = config.context](planet::CallResult result) {
                               if (!result.ok()) spdlog::warn("bridge: context {} not set: {}", key, result.message);
                             });
}

// ---- CAMUS side ------------------------------------------------------------------------------

void Bridge::poll_camus() {
  auto session = session_;
  if (!session->client || ((config_.services.empty() || !manager_) && !session->dds)) return;
  camus::ListRequest request;
  const auto result = session->client->call("camus.registry", "List", request.SerializeAsString(), kCamusTimeout);
  camus::ListReply reply;
  if (!result.ok() || !reply.ParseFromString(result.payload)) {
    if (warned_.insert("registry").second) {
      spdlog::warn("bridge: cannot list the CAMUS registry: {} {}", planet::status_name(result.status), result.message);
    }
    return;
  }
  warned_.erase("registry");
  std::map<std::string, const ServiceRule*> wanted;
  session->camus_native.clear();
  std::vector<ComponentState> agents;
  for (const auto& info : reply.services()) {
    if (info.state() != "available" || info.owner() == config_.name) continue;
    if (info.name().compare(0, 6, "camus.") == 0) continue;  // the server's own built-in services
    if (info.properties().count(kOrigin)) continue;  // a bridged service: never bridged again
    session->camus_native[info.name()] = info;
    agents.push_back({"", info.name(), "agent", "Available", info.interface(), info.owner(), {}});
    if (!manager_) continue;
    for (const auto& rule : config_.services) {
      if (glob_match(rule.match, info.name())) {
        wanted[info.name()] = &rule;
        break;
      }
    }
  }
  if (session->state) session->state->agent_states(agents);
  for (auto it = session->imports.begin(); it != session->imports.end();) {
    if (wanted.count(it->first)) {
      ++it;
      continue;
    }
    spdlog::info("bridge: CAMUS service {} is gone; withdrawing {}", it->first, it->second.path);
    manager_->destroy(*it->second.component);
    std::lock_guard lock(mutex_);
    it = session->imports.erase(it);
  }
  const auto now = Clock::now();
  for (const auto& [service, rule] : wanted) {
    if (session->imports.count(service)) continue;
    auto retry = session->import_retry.find(service);
    if (retry != session->import_retry.end() && now < retry->second) continue;
    std::string error;
    const gp::ServiceDescriptor* interface = describe_service(*session->client, service, session->remote, kCamusTimeout, error);
    const std::string instance = sanitize(expand(rule->instance, {{"service", service}}));
    try {
      if (interface == nullptr) throw std::runtime_error(error);
      rtc::ComponentSpec spec;
      spec.type = "CamusService";
      spec.instance_name = instance;
      spec.properties = {{kOrigin, "camus:" + service}, {"urslink.bridge", config_.name}};
      Session* s = session.get();
      const uint32_t deadline_ms = rule->deadline_ms;
      rtc::Component& created = manager_->create(spec, [s, service, interface, deadline_ms](const YAML::Node&,
                                                                                          const rtc::ComponentEnv&) {
        corba_agent::AgentComponentConfig settings;
        settings.type_name = "CamusService";
        settings.deadline = std::chrono::milliseconds(deadline_ms);
        return std::make_unique<corba_agent::AgentComponent>(
            settings, std::make_shared<CamusForwardingAgent>(*s->client, service, *interface));
      });
      std::lock_guard lock(mutex_);
      session->imports[service] = {&created, manager_->naming_path(created)};
      session->import_retry.erase(service);
      spdlog::info("bridge: CAMUS service {} offered to RT consumers as {}", service, manager_->naming_path(created));
    } catch (const std::exception& e) {
      session->import_retry[service] = now + std::chrono::seconds(10);
      spdlog::error("bridge: cannot offer CAMUS service {} as RTC {}: {} (trying again in 10 s)", service, instance,
                    e.what());
    }
  }
}

// ---- between spaces (DDS) ------------------------------------------------------------------

void Bridge::sync_dds_exports(Session& session) {
  if (!session.dds) return;
  const auto& dds = config_.dds;
  std::map<std::string, ServiceEntry> desired;
  std::map<std::string, bool> served;
  for (const auto& [key, name] : session.exports) {  // RT providers
    if (!allowed(name, dds.export_allow, dds.export_deny)) continue;
    const agent::HostedService* hosted = session.host.find(name);
    if (hosted == nullptr) continue;
    ServiceEntry entry;
    entry.name = name;
    entry.origin = hosted->properties.count(kOrigin) ? hosted->properties.at(kOrigin) : "rtc";
    entry.deadline_ms = hosted->deadline_ms;
    const auto known = session.announced.find(name);
    if (known == session.announced.end() || known->second.origin != entry.origin) {
      const gp::ServiceDescriptor& interface = hosted->agent->interface();
      entry.interface_name = interface.full_name();
      entry.repository_id = schema::repository_id(interface);
      entry.descriptor_set = schema::descriptor_set_for(*interface.file());
    } else {
      entry = known->second;
    }
    desired[name] = entry;
    served[name] = true;
  }
  for (const auto& [name, info] : session.camus_native) {  // this space's own service agents
    if (!allowed(name, dds.export_allow, dds.export_deny) || served.count(name)) continue;
    auto described = session.described.find(name);
    if (described == session.described.end()) {
      camus::DescribeRequest request;
      request.set_service(name);
      const auto result = session.client->call("camus.registry", "Describe", request.SerializeAsString(), kCamusTimeout);
      camus::DescribeReply reply;
      if (!result.ok() || !reply.ParseFromString(result.payload)) continue;  // tried again next poll
      const auto description = *session.descriptions.insert(std::make_shared<const std::string>(reply.descriptor_set())).first;
      described = session.described.emplace(name, description).first;
    }
    ServiceEntry entry;
    entry.name = name;
    entry.interface_name = info.interface();
    entry.origin = "camus";
    entry.deadline_ms = info.deadline_ms();
    // The description stays in `described` only (filled in when announced): copies in `desired`
    // and `announced` took two descriptor sets per service (docs/performance.md).
    desired[name] = entry;
    served[name] = false;
  }
  {
    std::lock_guard lock(session.served_mutex);
    session.served = served;
  }
  const bool refresh = Clock::now() - session.announced_at > config_.dds.lease;  // after a cut, the others relearn
  for (const auto& [name, entry] : desired) {
    const auto known = session.announced.find(name);
    const bool same = known != session.announced.end() && known->second.interface_name == entry.interface_name &&
                      known->second.origin == entry.origin && known->second.deadline_ms == entry.deadline_ms;
    if (same && !refresh) continue;
    if (!same) spdlog::info("bridge: offering {} to the other spaces", name);
    const auto described = entry.descriptor_set.empty() ? session.described.find(name) : session.described.end();
    if (described != session.described.end()) {
      ServiceEntry full = entry;
      full.descriptor_set = *described->second;
      session.dds->announce(full);
    } else {
      session.dds->announce(entry);
    }
    session.announced[name] = entry;
  }
  if (refresh) session.announced_at = Clock::now();
  for (auto it = session.announced.begin(); it != session.announced.end();) {
    if (desired.count(it->first)) {
      ++it;
      continue;
    }
    spdlog::info("bridge: {} is no longer offered to the other spaces", it->first);
    session.dds->withdraw(it->first);
    it = session.announced.erase(it);
  }
}

void Bridge::serve_remote(Session& session, call::Request request, call::Responder responder) {
  bool on_host = false;
  {
    std::lock_guard lock(session.served_mutex);
    const auto it = session.served.find(request.service);
    if (it == session.served.end()) {
      responder.reply(call::Reply::error(call::Status::UNKNOWN_SERVICE, "space " + config_.space +
                                                                            " offers no service '" + request.service + "'"));
      return;
    }
    on_host = it->second;
  }
  if (on_host) {
    session.host.dispatch(std::move(request), std::move(responder));
  } else if (!session.client) {
    responder.reply(call::Reply::error(call::Status::UNAVAILABLE, "space " + config_.space + " has no CAMUS server"));
  } else if (request.oneway) {
    session.client->oneway(request.service, request.operation, std::move(request.payload));
  } else {
    session.client->call_async(request.service, request.operation, std::move(request.payload),
                               planet::deadline_left(request), planet::answering(std::move(responder)));
  }
}

void Bridge::poll_dds() {
  auto session = session_;
  if (!session || !session->dds) return;
  // The catalog is read when DDS said it changed, and once a lease anyway.
  const auto now = Clock::now();
  if (remote_pending_.exchange(false) || now - session->catalog_read_at > config_.dds.lease) {
    session->catalog_read_at = now;
    std::map<std::string, ServiceEntry> offered;  // by "<space>/<service>", allowed ones
    for (auto& entry : session->dds->catalog()) {
      std::string key = entry.space + "/" + entry.name;
      if (allowed(key, config_.dds.import_allow, config_.dds.import_deny)) offered.emplace(std::move(key), std::move(entry));
    }
    std::vector<std::string> gone;
    for (const auto& [key, remote] : session->remotes) {
      const auto it = offered.find(key);
      if (it == offered.end() || it->second.descriptor_set != remote.descriptor_set ||
          it->second.interface_name != remote.interface_name) {
        gone.push_back(key);
      }
    }
    for (const auto& key : gone) withdraw_remote(*session, key);
    for (const auto& [key, entry] : offered) {
      if (!session->remotes.count(key)) import_remote(*session, entry);
    }
  }
  sync_dds_exports(*session);
}

void Bridge::import_remote(Session& session, const ServiceEntry& entry) {
  const std::string key = entry.space + "/" + entry.name;
  auto& pool = session.space_pools[entry.space];
  if (!pool) pool = std::make_unique<schema::SchemaPool>();
  schema::SchemaPool* in = pool.get();
  if (!in->add_descriptor_set(entry.descriptor_set).empty()) {  // clashes with another of that space
    session.extra_pools.push_back(std::make_unique<schema::SchemaPool>());
    in = session.extra_pools.back().get();
    const std::string error = in->add_descriptor_set(entry.descriptor_set);
    if (!error.empty()) {
      spdlog::error("bridge: {} cannot be imported: {}", key, error);
      return;
    }
  }
  const gp::ServiceDescriptor* interface = in->find_service(entry.interface_name);
  if (interface == nullptr) {
    spdlog::error("bridge: {} cannot be imported: its description lacks {}", key, entry.interface_name);
    return;
  }
  DdsLink* link = session.dds.get();
  CamusForwardingAgent::Route route{
      [link, space = entry.space, name = entry.name](const std::string& operation, std::string payload,
                                                       std::chrono::milliseconds deadline) {
        return link->call(space, name, operation, std::move(payload), deadline);
      },
      [link, space = entry.space, name = entry.name](const std::string& operation, std::string payload) {
        return link->oneway(space, name, operation, std::move(payload));
      },
      "space " + entry.space};
  auto proxy = std::make_shared<CamusForwardingAgent>(route, entry.name, *interface);
  Session::Remote remote;
  remote.interface_name = entry.interface_name;
  remote.descriptor_set = entry.descriptor_set;
  const std::vector<std::pair<std::string, std::string>> names{{"space", entry.space}, {"service", entry.name}};
  const std::map<std::string, std::string> properties{{kOrigin, "dds:" + key},
                                                      {"urslink.bridge", config_.name},
                                                      {"urslink.space", entry.space}};
  if (session.client && !config_.dds.as_camus.empty()) {
    agent::HostedService hosted{expand(config_.dds.as_camus, names), proxy, properties, config_.dds.deadline_ms};
    try {
      session.host.add(hosted);
      remote.camus_name = hosted.name;
      session.client->register_service(agent::registration(hosted), [name = hosted.name](planet::CallResult r) {
        if (!r.ok()) spdlog::error("bridge: registering {} failed: {}: {}", name, planet::status_name(r.status), r.message);
      });
      spdlog::info("bridge: {} of space {} offered to CAMUS as {}", entry.name, entry.space, hosted.name);
    } catch (const std::exception& e) {
      spdlog::error("bridge: {} cannot be offered to CAMUS: {}", key, e.what());
    }
  }
  if (manager_ && !config_.dds.as_rtc.empty()) {
    rtc::ComponentSpec spec;
    spec.type = "RemoteService";
    spec.instance_name = sanitize(expand(config_.dds.as_rtc, names));
    spec.properties.assign(properties.begin(), properties.end());
    const auto deadline = std::chrono::milliseconds(config_.dds.deadline_ms);
    try {
      rtc::Component& created = manager_->create(spec, [proxy, deadline](const YAML::Node&, const rtc::ComponentEnv&) {
        corba_agent::AgentComponentConfig settings;
        settings.type_name = "RemoteService";
        settings.deadline = deadline;
        return std::make_unique<corba_agent::AgentComponent>(settings, proxy);
      });
      remote.component = &created;
      remote.path = manager_->naming_path(created);
      spdlog::info("bridge: {} of space {} offered to RT consumers as {}", entry.name, entry.space, remote.path);
    } catch (const std::exception& e) {
      spdlog::error("bridge: {} cannot be offered as RTC {}: {}", key, spec.instance_name, e.what());
    }
  }
  std::lock_guard lock(mutex_);
  session.remotes[key] = std::move(remote);
}

void Bridge::withdraw_remote(Session& session, const std::string& key) {
  auto it = session.remotes.find(key);
  if (it == session.remotes.end()) return;
  spdlog::info("bridge: {} is gone from the other spaces; withdrawing it", key);
  if (!it->second.camus_name.empty()) {
    session.client->unregister_service(it->second.camus_name);
    session.host.remove(it->second.camus_name);
  }
  if (it->second.component) manager_->destroy(*it->second.component);
  std::lock_guard lock(mutex_);
  session.remotes.erase(it);
}

}  // namespace urs::bridge
