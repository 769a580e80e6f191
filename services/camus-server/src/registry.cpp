#include "urs/camus_server/registry.hpp"

#include <spdlog/spdlog.h>

#include <stdexcept>

#include "urs/camus_server/topic_pattern.hpp"

namespace urs::camus_server {

namespace gp = google::protobuf;

std::string service_name_problem(const std::string& name) {
  if (name.empty()) return "it is empty";
  if (name.size() > 200) return "it is longer than 200 characters";
  for (char c : name) {
    bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
              c == '_' || c == '-' || c == '@' || c == ':' || c == '/';
    if (!ok) return std::string("character '") + c + "' is not allowed (use letters, digits and . _ - @ : /)";
  }
  return {};
}

Registry::Registry(std::string space, agent::EventSink& events) : space_(std::move(space)), events_(events) {}

void Registry::publish_locked(const camus::ServiceInfo& info) {
  auto result = events_.publish("registry/" + info.name(), info);
  if (!result.ok()) spdlog::warn("registry event for {} not published: {}", info.name(), result.message);
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
    return make_error(planet::PERMISSION_DENIED, "registering services needs role sam; credential '" +
                                                     identity.name + "' has role " + planet::role_word(identity.role));
  }
  if (auto why = service_name_problem(name); !why.empty()) {
    return make_error(planet::BAD_ARGUMENTS, "service name '" + name + "' is not valid: " + why);
  }
  if (name.rfind("camus.", 0) == 0) {
    return make_error(planet::BAD_ARGUMENTS,
                      "service name '" + name + "' is not valid: names starting with 'camus.' are reserved for the server");
  }
  if (info.interface().empty()) {
    return make_error(planet::BAD_ARGUMENTS, "service " + name + ": interface is empty (give the full Protobuf service name)");
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

  std::lock_guard<std::mutex> lock(mutex_);
  auto it = services_.find(name);
  if (it != services_.end()) {
    const Entry& existing = it->second;
    bool same_session = existing.owner && existing.owner_session == session->id();
    bool resumed = existing.owner && existing.owner_resumable == identity.session;
    if (!same_session && !resumed) {
      return make_error(planet::ALREADY_EXISTS,
                        "service " + name + " is provided by " + existing.info.owner());
    }
  }
  Entry entry;
  entry.info = info;
  entry.info.set_owner(identity.name);
  entry.info.set_peer_name(session->hello().peer_name());
  entry.info.set_state("available");
  entry.owner = session;
  entry.owner_session = session->id();
  entry.owner_resumable = identity.session;
  if (!schema) {
    // Keep the interface known from an earlier registration, if any.
    auto known = interfaces_.find(info.interface());
    if (known != interfaces_.end()) schema = known->second;
  } else {
    interfaces_[info.interface()] = schema;
  }
  entry.schema = schema;
  services_[name] = entry;
  spdlog::info("service {} ({}) registered by {} (session {}, peer '{}')", name, info.interface(), identity.name,
               identity.session, session->hello().peer_name());
  publish_locked(entry.info);
  return Done{};
}

Result<Done> Registry::unregister_service(const planet::Session& session, const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = services_.find(name);
  if (it == services_.end()) return make_error(planet::UNKNOWN_SERVICE, "no service named '" + name + "' in space " + space_);
  const Entry& entry = it->second;
  bool resumed = entry.owner_resumable == session.identity().session;
  if (!entry.owner || (entry.owner_session != session.id() && !resumed)) {
    return make_error(planet::PERMISSION_DENIED,
                      "service " + name + " is provided by " + entry.info.owner() + "; only its provider may unregister it");
  }
  camus::ServiceInfo gone = entry.info;
  gone.set_state("gone");
  services_.erase(it);
  spdlog::info("service {} unregistered by {}", name, session.identity().name);
  publish_locked(gone);
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
      return make_error(planet::UNKNOWN_SERVICE, "no service named '" + request.service() + "' in space " + space_);
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
  route.builtin = !it->second.owner;
  route.owner = it->second.owner;
  route.owner_name = it->second.info.owner();
  route.deadline_ms = it->second.info.deadline_ms();
  route.interface = it->second.info.interface();
  route.schema = it->second.schema;
  return route;
}

std::vector<std::string> Registry::remove_session(uint64_t session_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> removed;
  for (auto it = services_.begin(); it != services_.end();) {
    if (it->second.owner && it->second.owner_session == session_id) {
      camus::ServiceInfo gone = it->second.info;
      gone.set_state("gone");
      removed.push_back(it->first);
      spdlog::info("service {} gone: provider {} disconnected", it->first, gone.owner());
      it = services_.erase(it);
      publish_locked(gone);
    } else {
      ++it;
    }
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
  return planet::CallResult::error(planet::BAD_ARGUMENTS, "payload of " + request.service() + "." +
                                                              request.operation() + " is not a valid " +
                                                              type.full_name());
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
      return planet::CallResult::error(planet::PERMISSION_DENIED,
                                       "only the provider may unregister " + in.name() + "; the caller is inside the server");
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
