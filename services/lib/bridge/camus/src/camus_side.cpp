#include "urs/bridge/camus/camus_side.hpp"

#include <google/protobuf/struct.pb.h>
#include <spdlog/spdlog.h>

#include "camus.pb.h"
#include "urs/agent/camus.hpp"
#include "urs/agent/client_sink.hpp"
#include "urs/bridge/camus/planet_forwarding.hpp"
#include "urs/bridge/core/route_reconciler.hpp"
#include "urs/bridge/core/rules.hpp"
#include "urs/planet/call_adapter.hpp"
#include "urs/schema/json.hpp"
#include "urs/util/error.hpp"

namespace urs::bridge {

namespace gp = google::protobuf;
using SystemClock = std::chrono::system_clock;

namespace {

constexpr auto kCamusTimeout = std::chrono::milliseconds(2000);  // a registry or context call
constexpr const char* kContextPrefix = "context/";
constexpr const char* kImportedSource = "dds:";       // source of imported context entries: "dds:<space>"
constexpr const char* kRegistryPrefix = "registry/";  // the registry's events: registry/<service>
using core::kBridgeProperty;
using core::kHealthProperty;
using core::kOriginProperty;

SystemClock::time_point from_unix_ns(int64_t ns) {
  return SystemClock::time_point(std::chrono::duration_cast<SystemClock::duration>(std::chrono::nanoseconds(ns)));
}

// True if `event` is the registry's, about a service another space offers here: registered by a
// bridge with the origin of a DDS offer ("dds:<space>/<service>"), also when it leaves.
bool of_an_import(const planet::Event& event) {
  if (event.topic().rfind(kRegistryPrefix, 0) != 0) return false;
  camus::ServiceInfo info;
  if (!info.ParseFromString(event.payload())) return false;
  for (const auto* properties : {&info.properties(), &info.changed_provider().properties()}) {
    const auto origin = properties->find(kOriginProperty);
    if (origin != properties->end()) return origin->second.rfind(kImportedSource, 0) == 0;
  }
  return false;
}

}  // namespace

// One Planet session. Destroyed: subscriptions first (no handler runs after), then the threads
// handing state over, the host, the client.
struct CamusSide::Session {
  ~Session() {
    if (client) {
      for (uint64_t id : state_subscriptions) client->unsubscribe(id);
      for (uint64_t id : subscriptions) client->unsubscribe(id);
    }
    exporter.stop();
    if (host) host->stop();
    importer.stop();
    if (client) client->stop();
  }

  std::shared_ptr<planet::Client> client;  // shared with the forwarding agents' sinks (weakly)
  std::unique_ptr<agent::ClientEventSink> events;
  gp::DynamicMessageFactory factory;
  std::unique_ptr<agent::AgentHost> host;     // after factory and events, which it uses
  std::vector<uint64_t> subscriptions;        // the registry's events, the streams'
  std::vector<uint64_t> state_subscriptions;  // this space's events and context shared
  agent::WorkerPool exporter{1};              // this space's events and context changes, in order, to the state sink
  agent::WorkerPool importer{1};              // other spaces' state, in order, into CAMUS

  std::mutex spaces_mutex;
  std::set<std::string> imported_spaces;  // spaces whose events this bridge publishes here
  std::mutex imports_mutex;               // the newest of each imported key not yet written (alive, entry)
  std::map<std::string, std::pair<bool, core::StateEntry>> imports;
};

CamusSide::CamusSide(CamusSideConfig config, const schema::InterfaceCatalog& catalog, planet::ClientOptions client)
    : core::Side("camus"), config_(std::move(config)), catalog_(catalog), client_options_(std::move(client)) {
  client_options_.peer_name = config_.bridge;
  client_options_.role = planet::SAM;
  std::vector<std::string> errors;
  for (std::size_t i = 0; i < config_.subscribe.size(); ++i) {
    if (catalog_.find_message(config_.subscribe[i].type) == nullptr) {
      errors.push_back("events_to_rt[" + std::to_string(i) + "].type: no message type " + config_.subscribe[i].type +
                       " is known (add its IDL under idl:)");
    }
  }
  if (!errors.empty()) {
    std::string text = "CAMUS side:";
    for (const auto& error : errors) text += "\n  " + error;
    throw util::ConfigError(text);
  }
}

CamusSide::~CamusSide() { close(); }

void CamusSide::start(core::SideEvents& events) { events_ = &events; }

std::string CamusSide::not_ready() const {
  const auto session = this->session();
  if (!session) return "not open";
  return session->client->connected() ? std::string() : "not connected to the CAMUS server";
}

std::shared_ptr<CamusSide::Session> CamusSide::session() const {
  std::lock_guard lock(session_mutex_);
  return session_;
}

void CamusSide::open() {
  auto session = std::make_shared<Session>();
  session->client = std::make_shared<planet::Client>(client_options_);
  planet::Client& client = *session->client;
  session->events = std::make_unique<agent::ClientEventSink>(client);
  session->factory.SetDelegateToGeneratedFactory(true);
  session->host = std::make_unique<agent::AgentHost>(agent::HostOptions{config_.workers, config_.queue, "queue"},
                                                     *session->events, &session->factory);
  agent::serve_requests(client, *session->host);
  client.on_connected([this](const planet::Welcome& welcome) {
    spdlog::info("bridge {}: connected to the CAMUS server of space {}", config_.bridge, welcome.space());
    events_->offers_changed();
  });
  client.on_disconnected([this](const std::string& reason) {
    spdlog::warn("bridge {}: lost the CAMUS server: {}; reconnecting", config_.bridge, reason);
  });
  // The server publishes registry/<name> on every change of a service: the offers are read again
  // then, not at the next period.
  session->subscriptions.push_back(
      client.subscribe("registry/#", [this](const planet::Event&) { events_->offers_changed(); }));
  for (std::size_t i = 0; i < config_.subscribe.size(); ++i) {
    const gp::Descriptor* type = catalog_.find_message(config_.subscribe[i].type);
    auto factory = std::make_shared<gp::DynamicMessageFactory>();
    factory->SetDelegateToGeneratedFactory(true);
    session->subscriptions.push_back(
        client.subscribe(config_.subscribe[i].topic, [this, i, type, factory](const planet::Event& event) {
          if (event.content_type() != type->full_name()) {
            spdlog::debug("bridge: event on {} is a {}, not {}; not streamed", event.topic(), event.content_type(),
                          type->full_name());
            return;
          }
          std::unique_ptr<gp::Message> value(factory->GetPrototype(type)->New());
          if (!value->ParseFromString(event.payload())) {
            spdlog::warn("bridge: event {} on {} is not a valid {}; not streamed", event.seq(), event.topic(),
                         type->full_name());
            return;
          }
          std::lock_guard lock(stream_mutex_);
          if (stream_sink_ != nullptr) stream_sink_->write(i, *value);
        }));
  }
  client.start();
  session->host->start();
  if (config_.import_state) clear_stale_imports(*session);
  std::lock_guard lock(session_mutex_);
  session_ = std::move(session);
}

void CamusSide::close() {
  std::shared_ptr<Session> session;
  {
    std::lock_guard lock(session_mutex_);
    session.swap(session_);
  }
}

// ---- services ----

std::optional<std::vector<core::Offer>> CamusSide::offers() {
  const auto session = this->session();
  if (!session) return std::nullopt;
  camus::ListRequest request;
  const auto result = session->client->call("camus.registry", "List", request.SerializeAsString(), kCamusTimeout);
  camus::ListReply reply;
  if (!result.ok() || !reply.ParseFromString(result.payload)) {
    if (!warned_registry_) {
      spdlog::warn("bridge: cannot list the CAMUS registry: {} {}", planet::status_name(result.status), result.message);
    }
    warned_registry_ = true;
    return std::nullopt;
  }
  warned_registry_ = false;
  std::vector<core::Offer> offers;
  std::vector<core::ComponentState> agents;
  for (const auto& info : reply.services()) {
    if (info.state() != "available" || info.owner() == config_.bridge) continue;
    core::Offer offer;
    offer.key = info.name();
    offer.name = info.name();
    offer.interface_name = info.interface();
    const auto origin = info.properties().find(kOriginProperty);
    if (origin != info.properties().end()) offer.origin = origin->second.empty() ? "(empty)" : origin->second;
    offer.built_in = info.name().compare(0, 6, "camus.") == 0;  // the server's own services
    offer.fields = {{"service", info.name()}};
    offer.source = "camus:" + info.name();
    offer.deadline_ms = info.deadline_ms();
    if (core::bridgeable(offer)) agents.push_back({info.name(), "agent", "Available", info.interface(), info.owner()});
    offers.push_back(std::move(offer));
  }
  if (config_.share_agents) {
    std::lock_guard lock(state_mutex_);
    if (state_sink_ != nullptr) state_sink_->components("agent", agents);
  }
  return offers;
}

std::shared_ptr<agent::ServiceAgent> CamusSide::serve(const core::Route& route) {
  const auto session = this->session();
  if (!session) throw util::Unavailable("no CAMUS session");
  const gp::ServiceDescriptor& interface = describe_service(*session->client, route.offer.name, described_);
  return planet_forwarder(session->client, route.offer.name, interface);
}

std::map<std::string, std::string> CamusSide::properties_of(const core::Route& route) const {
  std::map<std::string, std::string> properties = route.offer.properties;
  properties[kOriginProperty] = route.offer.source;
  properties[kBridgeProperty] = config_.bridge;
  return properties;
}

void CamusSide::register_service(Session& session, const agent::HostedService& hosted, const std::string& what) {
  session.client->register_service(agent::registration(hosted), [name = hosted.name, what](planet::CallResult result) {
    if (result.ok()) {
      spdlog::info("bridge: {} offered to CAMUS as {}", what, name);
    } else {
      spdlog::error("bridge: offering {} as {} failed: {}: {}", what, name, planet::status_name(result.status),
                    result.message);
    }
  });
}

core::OfferOutcome CamusSide::offer(const core::Route& route, core::ServiceSource& from) {
  const auto session = this->session();
  if (!session) return core::OfferOutcome::refuse("no CAMUS session");
  if (session->host->find(route.name) != nullptr) {
    return core::OfferOutcome::refuse("another service is offered to CAMUS as " + route.name);
  }
  agent::HostedService hosted{route.name, from.serve(route), properties_of(route), route.deadline_ms};
  session->host->add(hosted);
  register_service(*session, hosted, route.offer.name);
  return core::OfferOutcome::done();
}

void CamusSide::withdraw(const core::Route& route) {
  const auto session = this->session();
  if (!session) return;
  spdlog::info("bridge: withdrawing {} from CAMUS (stood for {})", route.name, route.offer.name);
  session->client->unregister_service(route.name);
  session->host->remove(route.name);
}

void CamusSide::update(const core::Route& route) {
  const auto session = this->session();
  if (!session) return;
  const agent::HostedService* hosted = session->host->find(route.name);
  if (hosted == nullptr) return;
  agent::HostedService updated = *hosted;
  updated.properties = properties_of(route);
  updated.deadline_ms = route.deadline_ms;
  const auto health = updated.properties.find(kHealthProperty);
  if (health != updated.properties.end()) {
    spdlog::info("bridge: {} is {} ({})", route.name, health->second, route.offer.name);
  }
  // Registering again under the same name replaces the registry's entry.
  session->client->register_service(agent::registration(updated));
}

// ---- state: this space's, out ----

void CamusSide::share_state(core::StateSink* sink) {
  const auto session = this->session();
  if (session) {  // the subscriptions end first: no handler posts after this
    for (uint64_t id : session->state_subscriptions) session->client->unsubscribe(id);
    session->state_subscriptions.clear();
  }
  {
    std::lock_guard lock(state_mutex_);
    state_sink_ = sink;
  }
  if (!session || sink == nullptr) return;
  Session* s = session.get();
  // Events arrive on the Planet client's I/O thread: they are handed over on the exporter's.
  for (const auto& pattern : config_.share_events) {
    s->state_subscriptions.push_back(s->client->subscribe(pattern, [this, s](const planet::Event& e) {
      s->exporter.post([this, s, e](bool cancelled) {
        if (!cancelled) export_event(*s, e);
      });
    }));
  }
  if (config_.share_context_allow.empty()) return;
  s->state_subscriptions.push_back(
      s->client->subscribe(std::string(kContextPrefix) + "#", [this, s](const planet::Event& e) {
        s->exporter.post([this, s, e](bool cancelled) {
          if (!cancelled) export_context(*s, e);
        });
      }));
  // What the context holds already (the subscription brings the changes from now on).
  s->exporter.post([this, s](bool cancelled) {
    if (cancelled) return;
    camus::ContextListRequest request;
    const auto listed = s->client->call("camus.context", "List", request.SerializeAsString(), kCamusTimeout);
    camus::ContextListReply reply;
    if (!listed.ok() || !reply.ParseFromString(listed.payload)) {
      spdlog::warn("bridge: cannot list the CAMUS context to share it: {} {}", planet::status_name(listed.status),
                   listed.message);
      return;
    }
    for (const auto& entry : reply.entries()) {
      planet::Event event;
      event.set_topic(kContextPrefix + entry.key());
      event.set_payload(entry.SerializeAsString());
      export_context(*s, event);
    }
  });
}

void CamusSide::export_event(Session& session, const planet::Event& event) {
  // Imported events (published by this bridge on <space>/...) are not shared again, nor the
  // registry's events of imported services (the other space's, as its context entries are);
  // context has its own topic.
  if (event.topic().rfind(kContextPrefix, 0) == 0 || of_an_import(event)) return;
  if (event.source() == session.client->welcome().identity()) {
    std::lock_guard lock(session.spaces_mutex);
    if (session.imported_spaces.count(event.topic().substr(0, event.topic().find('/')))) return;
  }
  const core::StateEvent shared{"",
                                event.seq(),
                                event.topic(),
                                event.content_type(),
                                event.source(),
                                from_unix_ns(event.time_unix_ns()),
                                event.payload()};
  std::lock_guard lock(state_mutex_);
  if (state_sink_ != nullptr) state_sink_->event(shared);
}

void CamusSide::export_context(Session& /*session*/, const planet::Event& event) {
  const std::string key = event.topic().substr(std::string(kContextPrefix).size());
  if (!allowed(key, config_.share_context_allow, config_.share_context_deny)) return;
  camus::ContextEntry entry;
  if (!entry.ParseFromString(event.payload())) {
    spdlog::warn("bridge: context change {} is not a ContextEntry; not shared", key);
    return;
  }
  core::StateEntry shared;
  shared.key = key;
  // Imported from another space, removed (or expired), or now holding another space's value: no
  // longer this space's to share. The sink ends only a key it shared, so the removal of an
  // imported key is never shared either.
  const bool alive = !entry.value().has_null_value() && entry.origin().rfind(kImportedSource, 0) != 0;
  if (alive) {
    shared.source = entry.source();
    shared.version = entry.version();
    shared.stamp = from_unix_ns(entry.updated_unix_ns());
    if (const std::string error = schema::message_to_json(entry.value(), shared.value_json); !error.empty()) {
      spdlog::warn("bridge: context {} cannot be shared: {}", key, error);
      return;
    }
  }
  std::lock_guard lock(state_mutex_);
  if (state_sink_ != nullptr) state_sink_->entry(shared, alive);
}

// ---- state: other spaces', in ----

// Entries come faster than context writes may be worth (a robot's pose): only the newest of each
// key waits to be written.
void CamusSide::entry(const core::StateEntry& entry, bool alive) {
  const auto session = this->session();
  if (!session) return;
  const std::string key = entry.space + "/" + entry.key;
  {
    std::lock_guard lock(session->imports_mutex);
    const bool waiting = session->imports.count(key) != 0;
    session->imports[key] = {alive, entry};
    if (waiting) return;
  }
  Session* s = session.get();
  s->importer.post([this, s, key](bool cancelled) {
    if (!cancelled) import_next(*s, key);
  });
}

void CamusSide::import_next(Session& session, const std::string& key) {
  std::pair<bool, core::StateEntry> newest;
  {
    std::lock_guard lock(session.imports_mutex);
    const auto it = session.imports.find(key);
    if (it == session.imports.end()) return;
    newest = std::move(it->second);
    session.imports.erase(it);
  }
  const auto& [alive, entry] = newest;
  if (!alive) {
    camus::ContextDeleteRequest request;
    request.set_key(key);
    const auto result = session.client->call("camus.context", "Delete", request.SerializeAsString(), kCamusTimeout);
    if (!result.ok() && result.status != planet::NOT_FOUND) {
      spdlog::warn("bridge: context {} of another space not removed: {} {}", key, planet::status_name(result.status),
                   result.message);
    }
    return;
  }
  camus::ContextSetRequest request;
  request.set_key(key);
  request.set_source(kImportedSource + entry.space);
  if (const std::string error = schema::json_to_message(entry.value_json, *request.mutable_value()); !error.empty()) {
    spdlog::warn("bridge: the value of {} from another space is not JSON: {}", key, error);
    return;
  }
  const auto result = session.client->call("camus.context", "Set", request.SerializeAsString(), kCamusTimeout);
  if (!result.ok()) {
    spdlog::warn("bridge: context {} from another space not set: {} {}", key, planet::status_name(result.status),
                 result.message);
  }
}

void CamusSide::event(const core::StateEvent& event) {
  const auto session = this->session();
  if (!session) return;
  {
    std::lock_guard lock(session->spaces_mutex);
    session->imported_spaces.insert(event.space);
  }
  Session* s = session.get();
  s->importer.post([s, event](bool cancelled) {
    const std::string topic = event.space + "/" + event.topic;
    if (cancelled) {
      spdlog::warn("bridge: stopping before event {} of space {} was published as {}", event.seq, event.space, topic);
      return;
    }
    const auto result = s->client->publish(topic, event.payload, event.content_type);
    if (!result.ok()) {
      spdlog::warn("bridge: event {} of space {} not published as {}: {} {}", event.seq, event.space, topic,
                   planet::status_name(result.status), result.message);
    }
  });
}

// Entries a previous run of this bridge imported: whatever still holds comes back.
void CamusSide::clear_stale_imports(Session& session) {
  Session* s = &session;
  s->importer.post([s](bool cancelled) {
    if (cancelled) return;
    camus::ContextListRequest request;
    const auto listed = s->client->call("camus.context", "List", request.SerializeAsString(), kCamusTimeout);
    camus::ContextListReply reply;
    if (!listed.ok() || !reply.ParseFromString(listed.payload)) return;
    for (const auto& entry : reply.entries()) {
      if (entry.origin().rfind(kImportedSource, 0) != 0) continue;
      camus::ContextDeleteRequest remove;
      remove.set_key(entry.key());
      s->client->call("camus.context", "Delete", remove.SerializeAsString(), kCamusTimeout);
    }
  });
}

// ---- streams ----

void CamusSide::stream_to(core::StreamSink* sink) {
  std::lock_guard lock(stream_mutex_);
  stream_sink_ = sink;
}

void CamusSide::write(std::size_t entry, const gp::Message& value) {
  const auto session = this->session();
  if (!session || entry >= config_.publish.size()) return;
  const CamusSideConfig::Publish& publish = config_.publish[entry];
  const auto published = session->client->publish(publish.topic, value.SerializeAsString(), value.GetTypeName());
  if (!published.ok()) spdlog::warn("bridge: value for {} not published: {}", publish.topic, published.message);
  if (publish.context.empty()) return;
  std::string json;
  camus::ContextSetRequest request;
  request.set_key(publish.context);
  request.set_source(config_.bridge);
  std::string error = schema::message_to_json(value, json);
  if (error.empty()) error = schema::json_to_message(json, *request.mutable_value());
  if (!error.empty()) {
    spdlog::warn("bridge: value for context {} cannot be converted: {}", publish.context, error);
    return;
  }
  session->client->call_async("camus.context", "Set", request.SerializeAsString(), kCamusTimeout,
                              [key = publish.context](planet::CallResult result) {
                                if (!result.ok()) spdlog::warn("bridge: context {} not set: {}", key, result.message);
                              });
}

}  // namespace urs::bridge
