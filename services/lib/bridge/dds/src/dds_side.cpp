#include "urs/bridge/dds/dds_side.hpp"

#include <fmt/format.h>
#include <google/protobuf/dynamic_message.h>
#include <spdlog/spdlog.h>

#include "urs/bridge/core/forwarding_agent.hpp"
#include "urs/bridge/core/route_reconciler.hpp"
#include "urs/federation/dds_security.hpp"
#include "urs/schema/schema.hpp"
#include "urs/util/error.hpp"
#include "urs/util/json_text.hpp"

namespace urs::bridge {

namespace gp = google::protobuf;
using Clock = std::chrono::steady_clock;

namespace {

// The calls of a forwarding agent to a service of another space, over the link.
class DdsCallSink : public core::CallSink {
 public:
  DdsCallSink(std::weak_ptr<federation::DdsLink> link, std::string space, std::string here)
      : link_(std::move(link)), space_(std::move(space)), here_(std::move(here)) {}

  bool start(call::Request& request, Done done) override {
    const auto link = link_.lock();
    if (!link) {
      done(closed());
      return true;
    }
    if (auto lost = unreachable(*link)) {
      done(std::move(*lost));
      return true;
    }
    if (request.oneway) {
      const std::optional<bool> sent = link->oneway_async(space_, request.service, request.operation,
                                                          std::move(request.payload), caller_name(request.caller));
      if (!sent) return false;
      done(*sent ? call::Reply::success({}) : not_sent());
      return true;
    }
    return link->call_async(space_, request.service, request.operation, std::move(request.payload), left(request),
                            caller_name(request.caller), std::move(done));
  }

  call::Reply call(call::Request request) override {
    const auto link = link_.lock();
    if (!link) return closed();
    if (auto lost = unreachable(*link)) return std::move(*lost);
    if (request.oneway) {
      return link->oneway(space_, request.service, request.operation, std::move(request.payload),
                          caller_name(request.caller))
                 ? call::Reply::success({})
                 : not_sent();
    }
    return link->call(space_, request.service, request.operation, std::move(request.payload), left(request),
                      caller_name(request.caller));
  }

  std::string to() const override { return "space " + space_; }

 private:
  // Who calls inside this space goes with the call: the name its CAMUS server authenticated.
  std::string caller_name(const call::Identity& caller) const {
    return caller.space.empty() || caller.space == here_ ? caller.name : std::string();
  }
  static std::chrono::milliseconds left(const call::Request& request) {
    if (!request.has_deadline()) return std::chrono::milliseconds(0);
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(request.deadline - Clock::now());
    return std::max(left, std::chrono::milliseconds(1));
  }
  // A space whose bridges are all lost is refused at once, by name (and counted as the link's
  // failure): a call would otherwise wait for a bridge of it to match until its deadline.
  std::optional<call::Reply> unreachable(federation::DdsLink& link) const {
    const auto since = link.lost_since(space_);
    if (!since) return std::nullopt;
    const auto ago = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - *since).count();
    call::Reply refused = call::Reply::error(
        call::Status::UNAVAILABLE, fmt::format("space {} is unreachable: every bridge of it was lost {}.{} s ago",
                                               space_, ago / 1000, ago % 1000 / 100));
    link.count_failure(space_, refused);
    return refused;
  }
  call::Reply closed() const {
    return call::Reply::error(call::Status::UNAVAILABLE, "the link to space " + space_ + " is closed");
  }
  call::Reply not_sent() const {
    return call::Reply::error(call::Status::UNAVAILABLE, "no bridge of space " + space_ + " takes it now");
  }

  const std::weak_ptr<federation::DdsLink> link_;
  const std::string space_;
  const std::string here_;
};

// A JSON object of the given members, each value already JSON.
std::string json_object(const std::vector<std::pair<const char*, std::string>>& members) {
  std::string out = "{";
  for (const auto& [name, value] : members) {
    if (out.size() > 1) out += ",";
    out += util::json_string(name) + ":" + value;
  }
  return out + "}";
}

int64_t unix_ns(std::chrono::system_clock::time_point t) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

}  // namespace

// One membership of the link. Destroyed state first, then the link (no call arrives after it),
// then the host of the agents serving this space's services.
struct DdsSide::Session {
  ~Session() {
    state.reset();
    link.reset();
    if (host) host->stop();
  }
  std::shared_ptr<CallAudit> audit;  // null: no audit log; kept by the responders of calls in flight
  agent::DiscardingEventSink events;
  gp::DynamicMessageFactory factory;
  std::unique_ptr<agent::AgentHost> host;
  std::shared_ptr<federation::DdsLink> link;
  std::unique_ptr<federation::StateLink> state;
  std::map<std::string, std::string> announced;  // stand-in name -> the offer's source; the bridge's thread only
};

DdsSide::DdsSide(DdsSideConfig config) : core::Side("dds"), config_(std::move(config)) {}

DdsSide::~DdsSide() { close(); }

void DdsSide::start(core::SideEvents& events) { events_ = &events; }

std::shared_ptr<DdsSide::Session> DdsSide::session() const {
  std::lock_guard lock(session_mutex_);
  return session_;
}

void DdsSide::open() {
  federation::DdsOptions options = config_.link;
  options.space = config_.space;
  options.bridge = config_.bridge;
  if (!config_.security_pki.empty()) {  // the folder's files where the configuration names none
    const federation::DdsSecurity folder = federation::security_from_folder(config_.security_pki, config_.space);
    for (auto field :
         {&federation::DdsSecurity::identity_ca, &federation::DdsSecurity::certificate,
          &federation::DdsSecurity::private_key, &federation::DdsSecurity::permissions_ca,
          &federation::DdsSecurity::governance, &federation::DdsSecurity::permissions, &federation::DdsSecurity::crl}) {
      if ((options.security.*field).empty()) options.security.*field = folder.*field;
    }
  }
  auto session = std::make_shared<Session>();
  if (!config_.audit.file.empty()) {
    try {
      session->audit = CallAudit::open(config_.audit);
    } catch (const std::exception& e) {
      throw util::ConfigError(std::string("dds.audit: ") + e.what());
    }
  }
  session->factory.SetDelegateToGeneratedFactory(true);
  session->host = std::make_unique<agent::AgentHost>(agent::HostOptions{config_.workers, config_.queue, "dds.queue"},
                                                     session->events, &session->factory);
  session->host->start();
  Session* serving = session.get();
  try {
    session->link = std::make_shared<federation::DdsLink>(
        options, [this] { events_->offers_changed(); },
        [this, serving](call::Request request, call::Responder responder) {
          serve_call(*serving, std::move(request), std::move(responder));
        });
  } catch (const std::exception& e) {
    failed_to_join_ = true;
    throw util::Unavailable(std::string("no link to other spaces yet: ") + e.what());
  }
  if (failed_to_join_) spdlog::info("bridge {}: joined the link to other spaces", config_.bridge);
  failed_to_join_ = false;
  std::string discovery;
  if (!options.discovery_listen.empty()) discovery = ", discovery server at " + options.discovery_listen;
  for (const auto& server : options.discovery_servers) discovery += ", discovery server " + server;
  spdlog::info(
      "bridge {}: space {} joined DDS domain {}{}{}{}", config_.bridge, config_.space, options.domain,
      options.udp_only ? " (UDP only)" : "", discovery,
      options.security.enabled() ? ", secured (DDS-Security, identity " + options.security.certificate + ")" : "");
  try {
    session->state = std::make_unique<federation::StateLink>(*session->link, importing(), config_.poses);
  } catch (const std::exception& e) {
    spdlog::error("bridge {}: the spaces share no state: {}", config_.bridge, e.what());
  }
  catalog_read_at_ = {};
  announced_at_ = joined_at_ = Clock::now();
  rejoin_asked_ = false;
  std::lock_guard lock(session_mutex_);
  session_ = std::move(session);
}

void DdsSide::close() {
  std::shared_ptr<Session> session;
  {
    std::lock_guard lock(session_mutex_);
    session.swap(session_);
  }
  {
    std::lock_guard lock(shared_mutex_);
    shared_components_.clear();
  }
  catalog_.clear();
  held_.clear();
  forwarding_.clear();
}

Clock::time_point DdsSide::poll(Clock::time_point now) {
  const auto lease = config_.link.lease;
  if (now - announced_at_ > lease) {  // after a cut the others relearn what this space offers
    announced_at_ = now;
    events_->stand_ins_lost();
  }
  Clock::time_point next = announced_at_ + lease + std::chrono::milliseconds(1);
  const federation::DdsOptions& link = config_.link;
  const bool connects_over_tcp = link.transport == federation::DdsOptions::Transport::kTcp &&
                                 (!link.tcp.connect.empty() || !link.discovery_servers.empty());
  if (connects_over_tcp && config_.rejoin_unmet.count() > 0 && !rejoin_asked_) {
    const std::shared_ptr<Session> session = this->session();
    if (session && session->link->catalog_writers_matched() == 0) {
      if (now - joined_at_ >= config_.rejoin_unmet) {
        std::string to;
        for (const auto& address : link.tcp.connect) to += (to.empty() ? "" : ", ") + address;
        for (const auto& address : link.discovery_servers) to += (to.empty() ? "" : ", ") + address;
        spdlog::warn(
            "bridge {}: the link over TCP to {} has met no one {:g} s after joining (no bridge matched: no site "
            "listening, or a connection that carries nothing, or discovery only): joining again",
            config_.bridge, to, std::chrono::duration<double>(now - joined_at_).count());
        rejoin_asked_ = true;
        events_->reopen();
      } else {
        next = std::min(next, joined_at_ + config_.rejoin_unmet);
      }
    }
  }
  for (const auto& [key, held] : held_) {
    if (held.until <= now) {
      events_->offers_changed();  // a hold ended: the offers are read again
      break;
    }
    next = std::min(next, held.until);
  }
  return next;
}

namespace {

// The offer of another space's service; `lost_at` (Unix seconds) while it is held with its space
// lost: shown unreachable since then.
core::Offer offer_of(const std::string& key, const federation::ServiceEntry& entry, std::optional<int64_t> lost_at) {
  core::Offer offer;
  offer.key = key;
  offer.name = key;
  offer.interface_name = entry.interface_name;
  offer.properties = {{"urslink.space", entry.space}};
  if (lost_at) {
    offer.properties[core::kHealthProperty] = "unreachable";
    offer.properties[core::kUnreachableSinceProperty] = std::to_string(*lost_at);
  }
  offer.fields = {{"space", entry.space}, {"service", entry.name}};
  offer.revision = entry.interface_name + "\n" + std::to_string(std::hash<std::string>()(entry.descriptor_set));
  offer.source = "dds:" + key;
  offer.deadline_ms = entry.deadline_ms;
  return offer;
}

}  // namespace

std::optional<std::vector<core::Offer>> DdsSide::offers() {
  const std::shared_ptr<Session> session = this->session();
  if (!session) return std::nullopt;
  const auto now = Clock::now();
  catalog_read_at_ = now;
  std::map<std::string, federation::ServiceEntry> before;
  before.swap(catalog_);
  std::vector<core::Offer> offers;
  for (auto& entry : session->link->catalog()) {
    std::string key = entry.space + "/" + entry.name;
    offers.push_back(offer_of(key, entry, std::nullopt));
    held_.erase(key);
    catalog_.insert_or_assign(std::move(key), std::move(entry));
  }
  // What left with its space (not withdrawn by it) stays, unreachable, until the hold ends. A space
  // back (a bridge of it alive again) announces all it offers within a lease: what it held stays,
  // reachable, for two leases more, and leaves then unless announced (it was withdrawn meanwhile).
  for (auto& [key, entry] : before) {
    if (catalog_.count(key)) continue;
    const auto since = session->link->lost_since(entry.space);
    auto held = held_.find(key);
    if (since) {
      if (*since + config_.hold_lost <= now) {
        if (held != held_.end()) {
          spdlog::info("bridge: {} leaves: space {} has been unreachable for {} ms", key, entry.space,
                       config_.hold_lost.count());
          held_.erase(held);
        }
        continue;
      }
      if (held == held_.end()) {
        spdlog::warn("bridge: space {} is unreachable: {} stays offered for {} ms, its calls refused", entry.space, key,
                     config_.hold_lost.count());
        held = held_.emplace(key, Held{}).first;
      }
      if (!held->second.lost || held->second.since != *since) {  // the wall time once per loss: a stable property
        const auto wall = std::chrono::system_clock::now() - (now - *since);
        held->second.lost_at = std::chrono::duration_cast<std::chrono::seconds>(wall.time_since_epoch()).count();
      }
      held->second.until = *since + config_.hold_lost;
      held->second.lost = true;
      held->second.since = *since;
    } else {
      if (held == held_.end()) continue;  // withdrawn by its space
      if (held->second.lost) {
        held->second.until = now + 2 * config_.link.lease;
        held->second.lost = false;
      } else if (held->second.until <= now) {
        spdlog::info("bridge: {} leaves: space {} is back without it", key, entry.space);
        held_.erase(held);
        continue;
      }
    }
    offers.push_back(offer_of(key, entry, held->second.lost ? std::optional(held->second.lost_at) : std::nullopt));
    catalog_.insert_or_assign(key, std::move(entry));
  }
  for (auto it = forwarding_.begin(); it != forwarding_.end();) {
    it = catalog_.count(it->first) ? std::next(it) : forwarding_.erase(it);
  }
  return offers;
}

std::shared_ptr<agent::ServiceAgent> DdsSide::serve(const core::Route& route) {
  const std::string& key = route.offer.key;
  const auto known = forwarding_.find(key);
  if (known != forwarding_.end() && known->second.revision == route.offer.revision) return known->second.agent;
  const auto found = catalog_.find(key);
  if (found == catalog_.end()) throw util::NotFound("no longer in the other spaces' catalog");
  const std::shared_ptr<Session> session = this->session();
  if (!session) throw util::Unavailable("not on the link");
  const federation::ServiceEntry& entry = found->second;
  auto& pool = space_pools_[entry.space];
  if (!pool) pool = std::make_unique<schema::SchemaPool>();
  schema::SchemaPool* in = pool.get();
  if (!in->add_descriptor_set(entry.descriptor_set).empty()) {  // clashes with another of that space
    extra_pools_.push_back(std::make_unique<schema::SchemaPool>());
    in = extra_pools_.back().get();
    const std::string error = in->add_descriptor_set(entry.descriptor_set);
    if (!error.empty()) throw util::ProtocolError("its description cannot be used: " + error);
  }
  const gp::ServiceDescriptor* interface = in->find_service(entry.interface_name);
  if (interface == nullptr) throw util::ProtocolError("its description lacks " + entry.interface_name);
  auto agent = std::make_shared<core::ForwardingAgent>(
      std::make_shared<DdsCallSink>(session->link, entry.space, config_.space), entry.name, *interface);
  forwarding_[key] = {route.offer.revision, agent};
  return agent;
}

core::OfferOutcome DdsSide::offer(const core::Route& route, core::ServiceSource& from) {
  const std::shared_ptr<Session> session = this->session();
  if (!session) return core::OfferOutcome::refuse("not on the link");
  if (const agent::HostedService* hosted = session->host->find(route.name)) {
    const auto held = session->announced.find(route.name);
    if (held == session->announced.end() || held->second != route.offer.source) {
      return core::OfferOutcome::refuse("another service is offered to the other spaces as " + route.name);
    }
    // The same offer again, after stand_ins_lost(): the others may have forgotten it (a cut longer
    // than the lease), so it is announced again; its agent stays.
    announce(route, *hosted->agent);
    return core::OfferOutcome::done();
  }
  std::shared_ptr<agent::ServiceAgent> agent = from.serve(route);
  session->host->add({route.name, agent, {}, route.deadline_ms ? route.deadline_ms : route.offer.deadline_ms});
  if (session->announced.insert_or_assign(route.name, route.offer.source).second) {
    spdlog::info("bridge: offering {} to the other spaces", route.name);
  }
  announce(route, *agent);
  return core::OfferOutcome::done();
}

void DdsSide::announce(const core::Route& route, const agent::ServiceAgent& agent) {
  const std::shared_ptr<Session> session = this->session();
  if (!session) return;
  const gp::ServiceDescriptor& interface = agent.interface();
  federation::ServiceEntry entry;
  entry.name = route.name;
  entry.interface_name = interface.full_name();
  entry.repository_id = schema::repository_id(interface);
  entry.origin = route.offer.source;
  entry.deadline_ms = route.deadline_ms ? route.deadline_ms : route.offer.deadline_ms;
  entry.descriptor_set = schema::descriptor_set_for(*interface.file());
  session->link->announce(entry);
}

void DdsSide::withdraw(const core::Route& route) {
  const std::shared_ptr<Session> session = this->session();
  if (!session) return;
  spdlog::info("bridge: {} is no longer offered to the other spaces", route.name);
  session->link->withdraw(route.name);
  session->host->remove(route.name);
  session->announced.erase(route.name);
}

void DdsSide::update(const core::Route& route) {
  const std::shared_ptr<Session> session = this->session();
  if (!session) return;
  const agent::HostedService* hosted = session->host->find(route.name);
  if (hosted != nullptr) announce(route, *hosted->agent);
}

namespace {

// A responder that records the call in `calls` when it is answered, under names of this space's
// catalog only: the service if this side offers it, the operation if its interface has it (else
// they count as "other": a peer's names make no series).
call::Responder recorded(call::CallRecorder& calls, const agent::AgentHost& host, const call::Request& request,
                         Clock::time_point arrived, call::Responder responder) {
  std::string service;
  std::string operation;
  if (const agent::HostedService* hosted = host.find(request.service)) {
    service = hosted->name;
    if (hosted->agent->interface().FindMethodByName(request.operation) != nullptr) operation = request.operation;
  }
  auto inner = std::make_shared<call::Responder>(std::move(responder));
  return call::Responder::from_callback(
      [&calls, service = std::move(service), operation = std::move(operation), arrived, inner](call::Reply reply) {
        calls.record(service, operation, reply.status, Clock::now() - arrived);
        inner->reply(std::move(reply));
      });
}

}  // namespace

std::shared_ptr<federation::DdsLink> DdsSide::link() const {
  const std::shared_ptr<Session> session = this->session();
  return session ? session->link : nullptr;
}

void DdsSide::serve_call(Session& session, call::Request request, call::Responder responder) {
  const auto arrived = Clock::now();
  if (served_calls_ != nullptr && !request.oneway) {
    responder = recorded(*served_calls_, *session.host, request, arrived, std::move(responder));
  }
  if (const std::optional<std::string> refused = refusal(config_.callers, config_.space, request)) {
    spdlog::info("bridge: refused a call from {}: {}", request.caller.name, *refused);
    if (session.audit) session.audit->record_refusal(request, *refused);
    responder.reply(call::Reply::error(call::Status::PERMISSION_DENIED, *refused));
    return;
  }
  if (session.audit) responder = session.audit->recording(request, arrived, std::move(responder));
  if (session.host->find(request.service) == nullptr) {
    responder.reply(call::Reply::error(call::Status::UNKNOWN_SERVICE,
                                       "space " + config_.space + " offers no service '" + request.service + "'"));
    return;
  }
  session.host->dispatch(std::move(request), std::move(responder));
}

// ---- state ----

void DdsSide::share_state(core::StateSink* sink) {
  std::lock_guard lock(sink_mutex_);
  sink_ = sink;
}

federation::StateHandlers DdsSide::importing() {
  federation::StateHandlers handlers;
  handlers.component = [this](const federation::ComponentState& c, bool alive) {
    std::lock_guard lock(sink_mutex_);
    if (sink_ == nullptr) return;
    core::StateEntry entry;
    entry.space = c.space;
    entry.key = "component/" + c.name;
    entry.value_json = json_object({{"kind", util::json_string(c.kind)},
                                    {"state", util::json_string(c.state)},
                                    {"type_name", util::json_string(c.type_name)},
                                    {"host", util::json_string(c.host)}});
    entry.stamp = c.stamp;
    sink_->entry(entry, alive);
  };
  handlers.context = [this](const federation::ContextState& e, bool alive) {
    std::lock_guard lock(sink_mutex_);
    if (sink_ != nullptr) sink_->entry({e.space, e.key, e.value_json, e.source, e.version, e.stamp}, alive);
  };
  handlers.pose = [this](const federation::SpacePose& pose) {
    std::lock_guard lock(sink_mutex_);
    if (sink_ == nullptr) return;
    core::StateEntry entry;
    entry.space = pose.space;
    entry.key = "pose/" + pose.robot;
    entry.value_json = json_object({{"x", fmt::format("{}", pose.x)},
                                    {"y", fmt::format("{}", pose.y)},
                                    {"theta", fmt::format("{}", pose.theta)},
                                    // A string, as Protobuf's JSON writes a 64-bit value: a
                                    // context value's number is a double, exact to 2^53 ns only.
                                    {"stamp_unix_ns", util::json_string(std::to_string(unix_ns(pose.stamp)))}});
    entry.stamp = pose.stamp;
    sink_->entry(entry, true);
  };
  handlers.event = [this](const federation::SpaceEvent& e) {
    std::lock_guard lock(sink_mutex_);
    if (sink_ != nullptr) sink_->event({e.space, e.seq, e.topic, e.content_type, e.source, e.stamp, e.payload});
  };
  return handlers;
}

void DdsSide::entry(const core::StateEntry& entry, bool alive) {
  const std::shared_ptr<Session> session = this->session();
  if (!session || !session->state) return;
  if (!alive) {
    session->state->drop_context(entry.key);
    return;
  }
  session->state->set_context({"", entry.key, entry.value_json, entry.source, entry.version, entry.stamp});
}

void DdsSide::event(const core::StateEvent& event) {
  const std::shared_ptr<Session> session = this->session();
  if (!session || !session->state) return;
  if (!session->state->publish_event(
          {"", event.seq, event.topic, event.content_type, event.source, event.stamp, event.payload})) {
    spdlog::error(
        "bridge: event {} on {} not shared over DDS: its history is full (the other spaces' bridges do not keep up)",
        event.seq, event.topic);
  }
}

void DdsSide::components(const std::string& kind, const std::vector<core::ComponentState>& now) {
  const std::shared_ptr<Session> session = this->session();
  if (!session || !session->state) return;
  std::lock_guard lock(shared_mutex_);
  std::set<std::string>& shared = shared_components_[kind];
  std::set<std::string> seen;
  for (const auto& c : now) {
    session->state->set_component({"", c.name, c.kind, c.state, c.type_name, c.host, {}});
    seen.insert(c.name);
  }
  for (const auto& name : shared) {
    if (!seen.count(name)) session->state->drop_component(name);
  }
  shared = std::move(seen);
}

}  // namespace urs::bridge
