#include "dds_adapter.hpp"

#include <spdlog/spdlog.h>

namespace urs::bridge {

namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kServedByCamus = "camus";  // the source of this space's CAMUS service agents

}  // namespace

DdsAdapter::DdsAdapter(const BridgeConfig& config, planet::Client* client, DdsLink::CatalogHandler catalog_changed,
                       Describe describe, Serve serve)
    : config_(config), describe_(std::move(describe)), serve_(std::move(serve)), announced_at_(Clock::now()) {
  DdsOptions options = config.dds.link;
  options.space = config.space;
  options.bridge = config.name;
  if (!config.dds.security_pki.empty()) {  // the folder's files where the configuration names none
    const DdsSecurity folder = security_from_folder(config.dds.security_pki, config.space);
    for (auto field : {&DdsSecurity::identity_ca, &DdsSecurity::certificate, &DdsSecurity::private_key,
                       &DdsSecurity::permissions_ca, &DdsSecurity::governance, &DdsSecurity::permissions,
                       &DdsSecurity::crl}) {
      if ((options.security.*field).empty()) options.security.*field = folder.*field;
    }
  }
  if (!config.dds.audit.file.empty()) audit_ = CallAudit::open(config.dds.audit);
  link_ = std::make_unique<DdsLink>(options, std::move(catalog_changed),
                                    [this](call::Request request, call::Responder responder) {
                                      serve_call(std::move(request), std::move(responder));
                                    });
  std::string discovery;
  if (!options.discovery_listen.empty()) discovery = ", discovery server at " + options.discovery_listen;
  for (const auto& server : options.discovery_servers) discovery += ", discovery server " + server;
  spdlog::info("bridge {}: space {} joined DDS domain {}{}{}{}", config.name, config.space, options.domain,
               options.udp_only ? " (UDP only)" : "", discovery,
               options.security.enabled() ? ", secured (DDS-Security, identity " + options.security.certificate + ")" : "");
  try {
    state_ = std::make_unique<SpaceState>(config, *link_, client);
  } catch (const std::exception& e) {
    spdlog::error("bridge {}: the spaces share no state: {}", config.name, e.what());
  }
}

DdsAdapter::~DdsAdapter() {
  state_.reset();
  link_.reset();
}

bool DdsAdapter::catalog_due(Clock::time_point now) const { return now - catalog_read_at_ > config_.dds.link.lease; }

std::vector<core::Offer> DdsAdapter::offers() {
  catalog_read_at_ = Clock::now();
  catalog_.clear();
  std::vector<core::Offer> offers;
  for (auto& entry : link_->catalog()) {
    std::string key = entry.space + "/" + entry.name;
    core::Offer offer;
    offer.key = key;
    offer.name = key;
    offer.interface_name = entry.interface_name;
    offer.properties = {{"urslink.space", entry.space}};
    offer.fields = {{"space", entry.space}, {"service", entry.name}};
    offer.revision = entry.interface_name + "\n" + std::to_string(std::hash<std::string>()(entry.descriptor_set));
    offer.source = "dds:" + key;
    offers.push_back(std::move(offer));
    catalog_.insert_or_assign(std::move(key), std::move(entry));
  }
  for (auto it = forwarding_.begin(); it != forwarding_.end();) {
    it = catalog_.count(it->first) ? std::next(it) : forwarding_.erase(it);
  }
  return offers;
}

std::shared_ptr<agent::ServiceAgent> DdsAdapter::forwarder(const core::Route& route) {
  const std::string& key = route.offer.key;
  const auto known = forwarding_.find(key);
  if (known != forwarding_.end() && known->second.revision == route.offer.revision) return known->second.agent;
  const auto found = catalog_.find(key);
  if (found == catalog_.end()) throw std::runtime_error("no longer in the other spaces' catalog");
  const ServiceEntry& entry = found->second;
  auto& pool = space_pools_[entry.space];
  if (!pool) pool = std::make_unique<schema::SchemaPool>();
  schema::SchemaPool* in = pool.get();
  if (!in->add_descriptor_set(entry.descriptor_set).empty()) {  // clashes with another of that space
    extra_pools_.push_back(std::make_unique<schema::SchemaPool>());
    in = extra_pools_.back().get();
    const std::string error = in->add_descriptor_set(entry.descriptor_set);
    if (!error.empty()) throw std::runtime_error("its description cannot be used: " + error);
  }
  const google::protobuf::ServiceDescriptor* interface = in->find_service(entry.interface_name);
  if (interface == nullptr) throw std::runtime_error("its description lacks " + entry.interface_name);
  DdsLink* link = link_.get();
  // Who calls inside this space goes with the call: the name its CAMUS server authenticated.
  auto caller_name = [here = config_.space](const call::Identity& caller) {
    return caller.space.empty() || caller.space == here ? caller.name : std::string();
  };
  CamusForwardingAgent::Route to_space{
      [link, caller_name, space = entry.space, name = entry.name](
          const std::string& operation, std::string payload, std::chrono::milliseconds deadline,
          const call::Identity& caller) {
        return link->call(space, name, operation, std::move(payload), deadline, caller_name(caller));
      },
      [link, caller_name, space = entry.space, name = entry.name](const std::string& operation, std::string payload,
                                                                  const call::Identity& caller) {
        return link->oneway(space, name, operation, std::move(payload), caller_name(caller));
      },
      [link, caller_name, space = entry.space, name = entry.name](
          const std::string& operation, std::string&& payload, std::chrono::milliseconds deadline,
          const call::Identity& caller, CamusForwardingAgent::Route::Done done) {
        return link->call_async(space, name, operation, std::move(payload), deadline, caller_name(caller),
                                std::move(done));
      },
      [link, caller_name, space = entry.space, name = entry.name](const std::string& operation, std::string&& payload,
                                                                  const call::Identity& caller) {
        return link->oneway_async(space, name, operation, std::move(payload), caller_name(caller));
      },
      "space " + entry.space};
  auto agent = std::make_shared<CamusForwardingAgent>(to_space, entry.name, *interface);
  forwarding_[key] = {route.offer.revision, agent};
  return agent;
}

bool DdsAdapter::announce_due(Clock::time_point now) {
  if (now - announced_at_ <= config_.dds.link.lease) return false;
  announced_at_ = now;
  return true;
}

core::OfferOutcome DdsAdapter::offer(const core::Route& route) {
  const std::optional<Description> description = describe_(route);
  if (!description || !description->descriptor_set) {
    return core::OfferOutcome::refuse("its description cannot be had now");
  }
  ServiceEntry entry;
  entry.name = route.name;
  entry.interface_name = description->interface_name;
  entry.repository_id = description->repository_id;
  entry.origin = route.offer.source;
  const auto deadline = route.offer.properties.find("deadline_ms");
  entry.deadline_ms = deadline == route.offer.properties.end() ? 0 : std::stoul(deadline->second);
  entry.descriptor_set = *description->descriptor_set;
  bool known = false;
  {
    std::lock_guard lock(served_mutex_);
    known = served_.count(route.name) > 0;
    served_[route.name] = route.offer.source != kServedByCamus;
  }
  if (!known) spdlog::info("bridge: offering {} to the other spaces", route.name);
  link_->announce(entry);
  return core::OfferOutcome::done();
}

void DdsAdapter::withdraw(const core::Route& route) {
  spdlog::info("bridge: {} is no longer offered to the other spaces", route.name);
  link_->withdraw(route.name);
  std::lock_guard lock(served_mutex_);
  served_.erase(route.name);
}

void DdsAdapter::update(const core::Route& route) { offer(route); }

void DdsAdapter::serve_call(call::Request request, call::Responder responder) {
  const auto arrived = Clock::now();
  if (const std::optional<std::string> refused = refusal(config_.dds.callers, config_.space, request)) {
    spdlog::info("bridge: refused a call from {}: {}", request.caller.name, *refused);
    if (audit_) audit_->record_refusal(request, *refused);
    responder.reply(call::Reply::error(call::Status::PERMISSION_DENIED, *refused));
    return;
  }
  if (audit_) responder = audit_->recording(request, arrived, std::move(responder));
  bool on_host = false;
  {
    std::lock_guard lock(served_mutex_);
    const auto it = served_.find(request.service);
    if (it == served_.end()) {
      responder.reply(call::Reply::error(call::Status::UNKNOWN_SERVICE,
                                         "space " + config_.space + " offers no service '" + request.service + "'"));
      return;
    }
    on_host = it->second;
  }
  serve_(std::move(request), on_host, std::move(responder));
}

}  // namespace urs::bridge
