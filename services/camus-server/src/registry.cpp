#include "urs/camus_server/registry.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <iterator>
#include <stdexcept>

#include "urs/camus_server/topic_pattern.hpp"

namespace urs::camus_server {

namespace gp = google::protobuf;

std::string service_name_problem(const std::string& name) {
  if (name.empty()) return "it is empty";
  if (name.size() > 200) return "it is longer than 200 characters";
  for (char c : name) {
    bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' ||
              c == '-' || c == '@' || c == ':' || c == '/';
    if (!ok) return std::string("character '") + c + "' is not allowed (use letters, digits and . _ - @ : /)";
  }
  // A service is announced on registry/<name>: every level between slashes needs a character.
  if (name.front() == '/' || name.back() == '/' || name.find("//") != std::string::npos) {
    return "it has an empty level (a '/' at its start or end, or '//'): each part between slashes needs a character";
  }
  return {};
}

Registry::Registry(std::string space, agent::EventSink& events) : space_(std::move(space)), events_(events) {}

std::vector<Registry::Provider>::iterator Registry::Entry::find(const planet::Session& session) {
  return std::find_if(providers.begin(), providers.end(), [&](const Provider& p) {
    return p.connection == session.id() || p.resumable == session.identity().session;
  });
}

void Registry::refresh_locked(Entry& entry) {
  if (entry.builtin()) return;
  const camus::ProviderInfo& first = entry.providers.front().info;
  entry.info.set_owner(first.owner());
  entry.info.set_peer_name(first.peer_name());
  *entry.info.mutable_properties() = first.properties();
  entry.info.set_deadline_ms(first.deadline_ms());
  entry.info.clear_providers();
  for (const auto& provider : entry.providers) *entry.info.add_providers() = provider.info;
}

void Registry::publish_locked(const Entry& entry, const std::string& state, const std::string& change,
                              const camus::ProviderInfo& provider) {
  camus::ServiceInfo event = entry.info;
  event.set_state(state);
  event.set_change(change);
  *event.mutable_changed_provider() = provider;
  auto result = events_.publish("registry/" + event.name(), event);
  if (!result.ok()) spdlog::warn("registry event for {} not published: {}", event.name(), result.message);
}

bool Registry::remove_provider_locked(std::map<std::string, Entry>::iterator it,
                                      std::vector<Provider>::iterator provider, const std::string& last_change) {
  Entry& entry = it->second;
  const camus::ProviderInfo leaving = provider->info;
  entry.providers.erase(provider);
  if (!entry.providers.empty()) {
    refresh_locked(entry);
    publish_locked(entry, "available", "provider-removed", leaving);
    return false;
  }
  Entry gone = std::move(entry);
  services_.erase(it);
  gone.info.clear_providers();
  publish_locked(gone, "gone", last_change, leaving);
  return true;
}

void Registry::add_builtin(const std::string& name, const gp::ServiceDescriptor& interface, uint32_t deadline_ms) {
  auto schema = InterfaceSchema::build(interface.full_name(), descriptor_set_for(*interface.file()));
  if (!schema.ok()) throw std::invalid_argument("built-in " + name + ": " + schema.message());
  std::lock_guard<std::mutex> lock(mutex_);
  if (services_.count(name) != 0) throw std::invalid_argument("built-in service '" + name + "' added twice");
  Entry entry;
  entry.info.set_name(name);
  entry.info.set_interface(interface.full_name());
  entry.info.set_owner(kServerPeerName);
  entry.info.set_state("available");
  entry.info.set_deadline_ms(deadline_ms);
  entry.schema = schema.value();
  interfaces_[interface.full_name()] = schema.value();
  services_.emplace(name, std::move(entry));
}

Result<Done> Registry::register_service(const planet::SessionPtr& session, const camus::RegisterRequest& request) {
  const auto& identity = session->identity();
  const auto& info = request.service();
  const std::string& name = info.name();
  if (identity.role < planet::SAM) {
    return make_error(planet::PERMISSION_DENIED, "registering services needs role sam; credential '" + identity.name +
                                                     "' has role " + planet::role_word(identity.role));
  }
  if (auto why = service_name_problem(name); !why.empty()) {
    return make_error(planet::BAD_ARGUMENTS, "service name " + quote_prefix(name) + " is not valid: " + why);
  }
  if (name.rfind("camus.", 0) == 0) {
    return make_error(planet::BAD_ARGUMENTS,
                      "service name " + quote_prefix(name) +
                          " is not valid: names starting with 'camus.' are reserved for the server");
  }
  if (info.interface().empty()) {
    return make_error(planet::BAD_ARGUMENTS,
                      "service " + name + ": interface is empty (give the full Protobuf service name)");
  }
  std::shared_ptr<const InterfaceSchema> schema;
  if (!request.descriptor_set().empty()) {
    // Providers of one interface send the same description: share its pool rather than build
    // one per registration (a pool costs ~200 KiB; a SAM may register hundreds of services).
    std::lock_guard<std::mutex> lock(mutex_);
    auto known = interfaces_.find(info.interface());
    if (known != interfaces_.end() && known->second->descriptor_set() == request.descriptor_set()) {
      schema = known->second;
    }
  }
  if (!schema && !request.descriptor_set().empty()) {
    auto built = InterfaceSchema::build(info.interface(), request.descriptor_set());
    if (!built.ok()) return make_error(built.status(), "service " + name + ": " + built.message());
    schema = built.value();
  }

  camus::ProviderInfo provider_info;
  provider_info.set_owner(identity.name);
  provider_info.set_peer_name(session->hello().peer_name());
  provider_info.set_connection(session->id());
  *provider_info.mutable_properties() = info.properties();
  provider_info.set_deadline_ms(info.deadline_ms());

  std::lock_guard<std::mutex> lock(mutex_);
  auto it = services_.find(name);
  std::string change = "registered";
  if (it != services_.end()) {
    Entry& existing = it->second;
    if (existing.builtin()) {
      return make_error(planet::ALREADY_EXISTS, "service " + name + " is provided by " + existing.info.owner());
    }
    auto mine = existing.find(*session);
    const bool others = existing.providers.size() > (mine == existing.providers.end() ? 0 : 1);
    if (mine == existing.providers.end() && existing.info.owner() != identity.name) {
      return make_error(planet::ALREADY_EXISTS, "service " + name + " is provided by " + existing.info.owner() +
                                                    "; only sessions of that credential may provide it too");
    }
    if (others && existing.info.interface() != info.interface()) {
      return make_error(planet::ALREADY_EXISTS, "service " + name + " is provided by " + existing.info.owner() +
                                                    " with interface " + existing.info.interface() +
                                                    "; another provider must register the same interface, not " +
                                                    quote_prefix(info.interface()));
    }
    if (others && schema && existing.schema && schema->descriptor_set() != existing.schema->descriptor_set()) {
      return make_error(planet::ALREADY_EXISTS, "service " + name + " is provided by " + existing.info.owner() +
                                                    " with another description of interface " + info.interface() +
                                                    " (its descriptor_set differs); another provider must "
                                                    "register the same one");
    }
    change = mine != existing.providers.end() ? "updated" : "provider-added";
  }
  if (!schema) {
    // Keep the interface known from an earlier registration, if any.
    auto known = interfaces_.find(info.interface());
    if (known != interfaces_.end()) schema = known->second;
  } else {
    interfaces_[info.interface()] = schema;
  }
  Provider provider;
  provider.session = session;
  provider.connection = session->id();
  provider.resumable = identity.session;
  provider.info = provider_info;
  if (it == services_.end()) it = services_.emplace(name, Entry{}).first;
  Entry& entry = it->second;
  if (change == "updated") {
    *entry.find(*session) = std::move(provider);
  } else {
    entry.providers.push_back(std::move(provider));
  }
  // The service's own fields: name and interface as registered, state "available"; its
  // description the one given (else the interface's known one), unless another provider's
  // description is already the service's.
  entry.info.set_name(name);
  entry.info.set_interface(info.interface());
  entry.info.set_state("available");
  if (change != "provider-added" || !entry.schema) entry.schema = schema;
  refresh_locked(entry);
  spdlog::info("service {} ({}) {} by {} (session {}, peer '{}'; {} provider{})", name, info.interface(),
               change == "registered" ? "registered"
               : change == "updated"  ? "registered again"
                                      : "also provided",
               identity.name, identity.session, session->hello().peer_name(), entry.providers.size(),
               entry.providers.size() == 1 ? "" : "s");
  publish_locked(entry, "available", change, provider_info);
  return Done{};
}

Result<Done> Registry::unregister_service(const planet::Session& session, const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = services_.find(name);
  if (it == services_.end())
    return make_error(planet::UNKNOWN_SERVICE, "no service named " + quote_prefix(name) + " in space " + space_);
  Entry& entry = it->second;
  auto mine = entry.find(session);
  if (entry.builtin() || mine == entry.providers.end()) {
    return make_error(planet::PERMISSION_DENIED, "service " + name + " is provided by " + entry.info.owner() +
                                                     "; only its provider may unregister it");
  }
  spdlog::info("service {} unregistered by {} (peer '{}')", name, session.identity().name, session.hello().peer_name());
  remove_provider_locked(it, mine, "unregistered");
  return Done{};
}
std::vector<camus::ServiceInfo> Registry::list(const std::string& pattern) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<camus::ServiceInfo> out;
  for (const auto& [name, entry] : services_) {
    if (pattern.empty() || glob_match(pattern, name)) out.push_back(entry.info);
  }
  return out;
}

Result<camus::DescribeReply> Registry::describe(const camus::DescribeRequest& request) const {
  std::lock_guard<std::mutex> lock(mutex_);
  camus::DescribeReply reply;
  if (!request.service().empty()) {
    auto it = services_.find(request.service());
    if (it == services_.end()) {
      return make_error(planet::UNKNOWN_SERVICE,
                        "no service named " + quote_prefix(request.service()) + " in space " + space_);
    }
    reply.set_interface(it->second.info.interface());
    if (!it->second.schema) {
      return make_error(planet::NOT_FOUND, "service " + request.service() + " was registered without a descriptor set");
    }
    reply.set_descriptor_set(it->second.schema->descriptor_set());
    return reply;
  }
  if (!request.interface().empty()) {
    auto it = interfaces_.find(request.interface());
    if (it == interfaces_.end()) {
      return make_error(planet::NOT_FOUND, "no registered service implements interface " + request.interface());
    }
    reply.set_interface(request.interface());
    reply.set_descriptor_set(it->second->descriptor_set());
    return reply;
  }
  if (!request.type().empty()) {
    for (const auto& [name, schema] : interfaces_) {
      if (schema->find_message(request.type()) == nullptr) continue;
      reply.set_interface(name);
      reply.set_descriptor_set(schema->descriptor_set());
      return reply;
    }
    return make_error(planet::NOT_FOUND, "no registered interface describes the type " + request.type());
  }
  return make_error(planet::BAD_ARGUMENTS, "Describe needs a service, an interface or a type name");
}

std::optional<Route> Registry::route(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = services_.find(name);
  if (it == services_.end()) return std::nullopt;
  Route route;
  route.builtin = it->second.builtin();
  for (const auto& provider : it->second.providers) {
    route.providers.push_back(RouteProvider{provider.session, provider.info.owner()});
  }
  route.deadline_ms = it->second.info.deadline_ms();
  route.interface = it->second.info.interface();
  route.schema = it->second.schema;
  return route;
}

std::vector<std::string> Registry::remove_session(uint64_t session_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> removed;
  for (auto it = services_.begin(); it != services_.end();) {
    auto next = std::next(it);
    auto& providers = it->second.providers;
    auto mine =
        std::find_if(providers.begin(), providers.end(), [&](const Provider& p) { return p.connection == session_id; });
    if (mine != providers.end()) {
      const std::string name = it->first;
      spdlog::info("service {}: provider {} (peer '{}') disconnected", name, mine->info.owner(),
                   mine->info.peer_name());
      if (remove_provider_locked(it, mine, "disconnected")) removed.push_back(name);
    }
    it = next;
  }
  return removed;
}

std::shared_ptr<const InterfaceSchema> Registry::schema_for_service(const std::string& service) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = services_.find(service);
  return it == services_.end() ? nullptr : it->second.schema;
}

std::shared_ptr<const InterfaceSchema> Registry::schema_with_message(const std::string& full_name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [name, schema] : interfaces_) {
    if (schema->find_message(full_name) != nullptr) return schema;
  }
  return nullptr;
}

namespace {

template <class T>
bool parse_payload(const planet::Request& request, T& out) {
  return out.ParseFromString(request.payload());
}

planet::CallResult bad_payload(const planet::Request& request, const gp::Descriptor& type) {
  return planet::CallResult::error(
      planet::BAD_ARGUMENTS,
      "payload of " + request.service() + "." + request.operation() + " is not a valid " + type.full_name());
}

planet::CallResult from(const Result<Done>& result, const gp::Message& reply) {
  if (!result.ok()) return planet::CallResult::error(result.status(), result.message());
  return planet::CallResult::success(reply.SerializeAsString());
}

}  // namespace

planet::CallResult RegistryService::handle(const planet::SessionPtr& caller, const planet::Request& request) {
  const std::string& op = request.operation();
  if (op == "Register") {
    camus::RegisterRequest in;
    if (!parse_payload(request, in)) return bad_payload(request, *in.GetDescriptor());
    if (!caller) {
      return planet::CallResult::error(planet::PERMISSION_DENIED,
                                       "only sessions may register services; the caller is inside the server");
    }
    return from(registry_.register_service(caller, in), camus::RegisterReply());
  }
  if (op == "Unregister") {
    camus::UnregisterRequest in;
    if (!parse_payload(request, in)) return bad_payload(request, *in.GetDescriptor());
    if (!caller) {
      return planet::CallResult::error(planet::PERMISSION_DENIED, "only the provider may unregister " + in.name() +
                                                                      "; the caller is inside the server");
    }
    return from(registry_.unregister_service(*caller, in.name()), camus::UnregisterReply());
  }
  if (op == "List") {
    camus::ListRequest in;
    if (!parse_payload(request, in)) return bad_payload(request, *in.GetDescriptor());
    camus::ListReply reply;
    for (auto& info : registry_.list(in.pattern())) *reply.add_services() = std::move(info);
    return planet::CallResult::success(reply.SerializeAsString());
  }
  if (op == "Describe") {
    camus::DescribeRequest in;
    if (!parse_payload(request, in)) return bad_payload(request, *in.GetDescriptor());
    auto reply = registry_.describe(in);
    if (!reply.ok()) return planet::CallResult::error(reply.status(), reply.message());
    return planet::CallResult::success(reply->SerializeAsString());
  }
  return planet::CallResult::error(planet::UNKNOWN_OPERATION,
                                   "interface urs.camus.Registry has no operation '" + op + "'");
}

}  // namespace urs::camus_server
