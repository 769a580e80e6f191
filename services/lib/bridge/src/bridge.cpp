#include "urs/bridge/bridge.hpp"

#include <spdlog/spdlog.h>

#include <cctype>
#include <set>

#include "bridge_component.hpp"
#include "camus_adapter.hpp"
#include "camus_stand_ins.hpp"
#include "connection_keeper.hpp"
#include "dds_adapter.hpp"
#include "rt_adapter.hpp"
#include "rt_stand_ins.hpp"
#include "urs/planet/call_adapter.hpp"
#include "urs/rtc/execution_context.hpp"
#include "urs/rtc/tools.hpp"
#include "urs/schema/schema.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::bridge {

namespace gp = google::protobuf;
using Clock = std::chrono::steady_clock;

namespace {

constexpr const char* kConnectorName = "urs-bridge";  // profile name prefix of the connections the watch makes
constexpr auto kRetryPeriod = std::chrono::milliseconds(2000);        // a stand-in its side refused
constexpr auto kServiceRetryPeriod = std::chrono::seconds(10);        // an RTC for a CAMUS service

std::string file_safe(const std::string& text) {
  std::string out = text;
  for (char& c : out) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') c = '_';
  }
  return out;
}

// The rules of each direction, as the core takes them.
std::vector<core::RouteRule> provider_rules(const BridgeConfig& config) {
  std::vector<core::RouteRule> rules;
  for (const auto& provider : config.providers) {
    rules.push_back({{provider.match}, {}, provider.interface, provider.name, provider.deadline_ms});
  }
  // Whatever else is connected to the providers port (`urs rtc con`, rtcon) is offered too.
  rules.push_back({{"*"}, {}, "*", ProviderRule{}.name, ProviderRule{}.deadline_ms});
  return rules;
}

std::vector<core::RouteRule> service_rules(const BridgeConfig& config) {
  std::vector<core::RouteRule> rules;
  for (const auto& service : config.services) {
    rules.push_back({{service.match}, {}, "*", service.instance, service.deadline_ms});
  }
  return rules;
}

core::RouteRule import_rule(const DdsConfig& dds, const std::string& name) {
  return {dds.import_allow, dds.import_deny, "*", name, dds.deadline_ms};
}

}  // namespace

// One activation: the adapters of the session, the stand-ins each side offers, and the routes.
// Declared so that the routes go first, then their targets, then the adapters.
struct Bridge::Session {
  std::unique_ptr<CamusAdapter> camus;
  std::unique_ptr<DdsAdapter> dds;  // with dds.enabled and the link up
  std::vector<CamusAdapter::Service> camus_services;  // this space's own, as last listed

  std::unique_ptr<CamusStandIns> on_camus_for_rt;
  std::unique_ptr<CamusStandIns> on_camus_for_dds;
  std::unique_ptr<RtStandIns> on_rt_for_camus;
  std::unique_ptr<RtStandIns> on_rt_for_dds;

  std::unique_ptr<core::RouteReconciler> providers_to_camus;  // with an RT side
  std::unique_ptr<core::RouteReconciler> services_to_rt;      // with an RT side, a CAMUS server and rules
  std::unique_ptr<core::RouteReconciler> remote_to_camus;     // with DDS, a CAMUS server and dds.import.as_camus
  std::unique_ptr<core::RouteReconciler> remote_to_rt;        // with DDS, an RT side and dds.import.as_rtc
  std::unique_ptr<core::RouteReconciler> space_to_dds;        // with DDS
};

Bridge::Bridge(rtc::Orb& orb, rtc::NamingClient* naming, rtc::Manager* manager, const InterfaceCatalog& catalog,
               BridgeConfig config, std::optional<planet::ClientOptions> planet)
    : orb_(orb), naming_(naming), manager_(manager), catalog_(catalog), config_(std::move(config)),
      planet_(std::move(planet)),
      link_retry_("bridge " + config_.name) {
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
    BridgeComponent::Hooks hooks{[this](bool active) { request_active(active); },
                                 [this](std::size_t entry, const gp::Message& value) { on_data(entry, value); }};
    auto component = std::make_unique<BridgeComponent>(config_, catalog_, std::move(hooks));
    component_ = component.get();
    return component;
  });
  const std::string own_path = manager_->naming_path(created);
  rt_ = std::make_unique<RtAdapter>(orb_, *naming_, catalog_, config_, *component_, own_path);
  connections_ = std::make_unique<ConnectionKeeper>(
      orb_, config_.data_dir.empty() ? std::string() : config_.data_dir + "/connections-" + file_safe(config_.name) + ".yaml",
      std::string(kConnectorName) + "." + config_.name);
  thread_ = std::thread([this] { run(); });
  if (config_.activate) {
    RTC::RTObject_var self = created.reference();
    RTC::ExecutionContextService_var context = created.execution_context().reference();
    const RTC::ReturnCode_t result = context->activate_component(self);
    if (result != RTC::RTC_OK) {
      throw std::runtime_error(own_path + ": activation returned " + rtc::return_code_name(result));
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
  if (!session_) return status;
  if (session_->providers_to_camus) {
    for (const auto& route : session_->providers_to_camus->routes()) {
      status.exported.push_back(route.name);
      const auto health = route.offer.properties.find(kHealthProperty);
      status.health[route.name] = health == route.offer.properties.end() ? "" : health->second;
    }
  }
  if (session_->on_rt_for_camus) status.imported = session_->on_rt_for_camus->paths();
  std::set<std::string> remote;
  for (const auto* routes : {session_->remote_to_camus.get(), session_->remote_to_rt.get()}) {
    if (routes == nullptr) continue;
    for (const auto& route : routes->routes()) remote.insert(route.offer.key);
  }
  status.remote.assign(remote.begin(), remote.end());
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
        auto next = std::min(next_rt, next_camus);
        if (config_.dds.enabled && !session_->dds) next = std::min(next, link_retry_.next_try());
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
        poll_rt(*session_);
        next_rt = Clock::now() + config_.rt_poll;
      }
      if (now >= next_camus) {
        poll_camus(*session_);
        next_camus = Clock::now() + config_.camus_poll;
      }
      if (config_.dds.enabled && !session_->dds && link_retry_.due(now)) join_link(*session_);
      poll_dds(*session_);
    } catch (const std::exception& e) {
      spdlog::error("bridge: {}", e.what());
      next_rt = next_camus = Clock::now() + config_.rt_poll;
    }
  }
}

void Bridge::open_session() {
  auto session = std::make_shared<Session>();
  std::vector<corba_agent::RawOutPort*> event_ports;
  for (std::size_t i = 0; component_ != nullptr && i < config_.events_to_rt.size(); ++i) {
    event_ports.push_back(&component_->out_port(i));
  }
  session->camus = std::make_unique<CamusAdapter>(config_, catalog_, planet_, std::move(event_ports));
  session->camus->start();
  CamusAdapter& camus = *session->camus;
  planet::Client* client = camus.client();

  // The stand-ins each side offers, and the routes that make them.
  const auto from_rt = [this](const core::Route& route) { return rt_->forwarder(route); };
  const auto from_camus = [&camus](const core::Route& route) { return camus.forwarder(route); };
  if (rt_) {
    session->on_camus_for_rt = std::make_unique<CamusStandIns>(camus.host(), client, config_.name, from_rt);
    session->providers_to_camus = std::make_unique<core::RouteReconciler>(
        "RT -> CAMUS", provider_rules(config_), *session->on_camus_for_rt, kRetryPeriod);
    if (client && !config_.services.empty()) {
      session->on_rt_for_camus = std::make_unique<RtStandIns>(*manager_, config_.name, "CamusService", from_camus);
      session->services_to_rt = std::make_unique<core::RouteReconciler>(
          "CAMUS -> RT", service_rules(config_), *session->on_rt_for_camus, kServiceRetryPeriod);
    }
  }
  {
    std::lock_guard lock(mutex_);
    session_ = session;
  }
  if (config_.dds.enabled) join_link(*session);
  if (connections_) connections_->load();
  if (planet_) {
    spdlog::info("bridge {}: active (CAMUS server {}:{})", config_.name, planet_->host, planet_->port);
  } else {
    spdlog::info("bridge {}: active (no CAMUS server)", config_.name);
  }
}

// The DDS side of a session: this space joins the link, offers its services to the other spaces and
// imports theirs. A link that cannot be joined yet (an initial peer or discovery server whose name
// resolves only once its container has started) leaves the rest of the space working; the run loop
// tries again every LinkRetry::kPeriod until it is joined.
void Bridge::join_link(Session& session) {
  CamusAdapter& camus = *session.camus;
  planet::Client* client = camus.client();
  Session* s = &session;
  std::unique_ptr<DdsAdapter> dds;
  try {
    dds = std::make_unique<DdsAdapter>(
        config_, client,
        [this] {
          remote_pending_ = true;
          wake_.notify_all();
        },
        [s](const core::Route& route) -> std::optional<DdsAdapter::Description> {
          if (route.offer.source == "camus") {
            auto description = s->camus->description(route.name);
            if (!description) return std::nullopt;
            return DdsAdapter::Description{route.offer.interface_name, "", std::move(description)};
          }
          const agent::HostedService* hosted = s->camus->host().find(route.name);
          if (hosted == nullptr) return std::nullopt;
          const gp::ServiceDescriptor& interface = hosted->agent->interface();
          return DdsAdapter::Description{interface.full_name(), schema::repository_id(interface),
                                         std::make_shared<const std::string>(schema::descriptor_set_for(*interface.file()))};
        },
        [this, s](call::Request request, bool on_host, call::Responder responder) {
          CamusAdapter& here = *s->camus;
          if (on_host) {
            here.host().dispatch(std::move(request), std::move(responder));
          } else if (here.client() == nullptr) {
            responder.reply(call::Reply::error(call::Status::UNAVAILABLE, "space " + config_.space + " has no CAMUS server"));
          } else if (request.oneway) {
            here.client()->oneway(request.service, request.operation, std::move(request.payload));
          } else {
            here.client()->call_async(request.service, request.operation, std::move(request.payload),
                                       planet::deadline_left(request), planet::answering(std::move(responder)));
          }
        });
  } catch (const std::exception& e) {
    link_retry_.failed(e.what());
    return;
  }
  DdsAdapter* link = dds.get();
  const auto from_dds = [link](const core::Route& route) { return link->forwarder(route); };
  std::unique_ptr<CamusStandIns> on_camus;
  std::unique_ptr<core::RouteReconciler> to_camus;
  if (client && !config_.dds.as_camus.empty()) {
    on_camus = std::make_unique<CamusStandIns>(camus.host(), client, config_.name, from_dds);
    to_camus = std::make_unique<core::RouteReconciler>("other spaces -> CAMUS",
                                                       std::vector{import_rule(config_.dds, config_.dds.as_camus)},
                                                       *on_camus, kServiceRetryPeriod);
  }
  std::unique_ptr<RtStandIns> on_rt;
  std::unique_ptr<core::RouteReconciler> to_rt;
  if (rt_ && !config_.dds.as_rtc.empty()) {
    on_rt = std::make_unique<RtStandIns>(*manager_, config_.name, "RemoteService", from_dds);
    to_rt = std::make_unique<core::RouteReconciler>(
        "other spaces -> RT", std::vector{import_rule(config_.dds, config_.dds.as_rtc)}, *on_rt, kServiceRetryPeriod);
  }
  auto to_dds = std::make_unique<core::RouteReconciler>(
      "this space -> other spaces",
      std::vector{core::RouteRule{config_.dds.export_allow, config_.dds.export_deny, "*", "{name}", 0}}, *link,
      kRetryPeriod);
  link_retry_.joined();
  std::lock_guard lock(mutex_);  // status() reads the routes
  session.dds = std::move(dds);
  session.on_camus_for_dds = std::move(on_camus);
  session.remote_to_camus = std::move(to_camus);
  session.on_rt_for_dds = std::move(on_rt);
  session.remote_to_rt = std::move(to_rt);
  session.space_to_dds = std::move(to_dds);
}

void Bridge::close_session() {
  std::shared_ptr<Session> session;
  {
    std::lock_guard lock(mutex_);
    session.swap(session_);
  }
  session->space_to_dds.reset();
  session->dds.reset();  // the others drop this space's services; no more calls arrive
  std::size_t withdrawn = 0;
  for (auto* routes : {session->remote_to_rt.get(), session->remote_to_camus.get(), session->services_to_rt.get(),
                       session->providers_to_camus.get()}) {
    if (routes == nullptr) continue;
    withdrawn += routes->routes().size();
    routes->withdraw_all();
  }
  session->camus->stop();
  spdlog::info("bridge {}: inactive; {} route(s) withdrawn", config_.name, withdrawn);
}

void Bridge::poll_rt(Session& session) {
  if (!rt_) return;
  SpaceState* state = session.dds ? session.dds->state() : nullptr;
  rt_->watch(state != nullptr && config_.dds.state.components);  // every RTC's state is shared
  session.providers_to_camus->reconcile(rt_->provider_offers());
  connections_->restore([this, &session](const std::string& key) -> rtc::Component* {
    for (const auto& [rtc_key, component] : our_rtcs(session)) {
      if (rtc_key == key) return component;
    }
    return nullptr;
  });
  connections_->save(our_rtcs(session));
  if (state != nullptr && state->rtc_states_due()) state->rtc_states(rt_->component_states());
}

std::vector<std::pair<std::string, rtc::Component*>> Bridge::our_rtcs(Session& session) const {
  std::vector<std::pair<std::string, rtc::Component*>> rtcs{{"bridge", component_}};
  for (const auto* stand_ins : {session.on_rt_for_camus.get(), session.on_rt_for_dds.get()}) {
    if (stand_ins == nullptr) continue;
    for (const auto& entry : stand_ins->components()) rtcs.push_back(entry);
  }
  return rtcs;
}

void Bridge::poll_camus(Session& session) {
  if (!session.services_to_rt && !session.dds) return;
  auto services = session.camus->list_services();
  if (!services) return;
  session.camus_services.clear();
  std::vector<core::Offer> offers;
  std::vector<ComponentState> agents;
  for (auto& service : *services) {
    if (core::bridgeable(service.offer)) {
      agents.push_back({"", service.offer.name, "agent", "Available", service.offer.interface_name, service.owner, {}});
      session.camus_services.push_back(service);
    }
    offers.push_back(std::move(service.offer));
  }
  if (session.dds && session.dds->state()) session.dds->state()->agent_states(agents);
  if (session.services_to_rt) session.services_to_rt->reconcile(offers);
}

void Bridge::poll_dds(Session& session) {
  if (!session.dds) return;
  if (remote_pending_.exchange(false) || session.dds->catalog_due(Clock::now())) {
    const std::vector<core::Offer> offers = session.dds->offers();
    if (session.remote_to_camus) session.remote_to_camus->reconcile(offers);
    if (session.remote_to_rt) session.remote_to_rt->reconcile(offers);
  }
  export_to_dds(session);
}

void Bridge::export_to_dds(Session& session) {
  std::vector<core::Offer> offers;
  std::set<std::string> names;
  if (session.providers_to_camus) {
    for (const auto& route : session.providers_to_camus->routes()) {  // RT providers, hosted
      const agent::HostedService* hosted = session.camus->host().find(route.name);
      if (hosted == nullptr) continue;
      core::Offer offer;
      offer.key = offer.name = route.name;
      offer.interface_name = hosted->agent->interface().full_name();
      offer.source = route.offer.source;
      offer.properties = {{"deadline_ms", std::to_string(hosted->deadline_ms)}};
      names.insert(route.name);
      offers.push_back(std::move(offer));
    }
  }
  for (const auto& service : session.camus_services) {  // this space's own service agents
    if (names.count(service.offer.name)) continue;
    core::Offer offer;
    offer.key = offer.name = service.offer.name;
    offer.interface_name = service.offer.interface_name;
    offer.source = "camus";
    offer.properties = {{"deadline_ms", std::to_string(service.deadline_ms)}};
    offers.push_back(std::move(offer));
  }
  if (session.dds->announce_due(Clock::now())) session.space_to_dds->target_restarted();  // the others relearn
  session.space_to_dds->reconcile(offers);
}

void Bridge::on_data(std::size_t entry, const gp::Message& value) {
  std::shared_ptr<Session> session;
  {
    std::lock_guard lock(mutex_);
    session = session_;
  }
  if (!session || !session->camus->client()) {
    spdlog::debug("bridge: inactive; a value for {} is not forwarded", config_.data_to_camus.at(entry).topic);
    return;
  }
  session->camus->relay(entry, value);
}

}  // namespace urs::bridge
