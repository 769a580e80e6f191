#pragma once
// The service registry: which service names exist in the space, who provides them and what
// their interface looks like.
//
// Rules:
//  - Sessions whose credential has role SAM or OPERATOR register services; the server fills owner
//    (the session's authenticated identity), peer_name (its declared name, for display) and state
//    "available" and publishes "registry/<name>" (ServiceInfo).
//  - A name owned by another session is refused: ALREADY_EXISTS "service X is provided by Y".
//    The same connection, or a connection that resumed the same session (planet::Identity::session,
//    proven by the server-issued session secret), replaces the registration.
//  - When the owning session closes, its services are removed and "registry/<name>" is published
//    with state "gone". Built-in services (owner "camus-server") cannot be replaced or removed.
//  - Descriptor sets are kept per interface (the latest registration wins).
//
// Threading: all methods are thread-safe and never block on I/O (events go to a non-blocking
// EventSink).

#include <google/protobuf/descriptor.h>

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "camus.pb.h"
#include "urs/agent/agent.hpp"
#include "urs/camus_server/names.hpp"
#include "urs/camus_server/result.hpp"
#include "urs/camus_server/schema.hpp"
#include "urs/planet/server.hpp"
#include "urs/planet/status.hpp"

namespace urs::camus_server {

// Interface descriptions by service or by message type (task manager, router).
class SchemaLookup {
 public:
  virtual ~SchemaLookup() = default;
  // nullptr if the service is unknown or was registered without a descriptor set.
  virtual std::shared_ptr<const InterfaceSchema> schema_for_service(const std::string& service) const = 0;
  // A schema whose pool defines the message type `full_name`; nullptr if none.
  virtual std::shared_ptr<const InterfaceSchema> schema_with_message(const std::string& full_name) const = 0;
};

// Where a call to a service goes.
struct Route {
  bool builtin = false;
  planet::SessionPtr owner;  // the provider (null for built-ins)
  std::string owner_name;
  uint32_t deadline_ms = 0;  // the service's default deadline (0 = none)
  std::string interface;
  std::shared_ptr<const InterfaceSchema> schema;  // null if no descriptor set was given
};

class Registry final : public SchemaLookup {
 public:
  Registry(std::string space, agent::EventSink& events);

  const std::string& space() const { return space_; }

  // Control plane: lists a service implemented inside the server. Throws std::invalid_argument
  // on a duplicate name.
  void add_builtin(const std::string& name, const google::protobuf::ServiceDescriptor& interface,
                   uint32_t deadline_ms = 0);

  // PERMISSION_DENIED for a session whose role is below SAM, BAD_ARGUMENTS for a bad
  // name/interface/descriptor set, ALREADY_EXISTS as described above.
  Result<Done> register_service(const planet::SessionPtr& session, const camus::RegisterRequest& request);
  // UNKNOWN_SERVICE if there is no such service; PERMISSION_DENIED if another session owns it.
  Result<Done> unregister_service(const planet::Session& session, const std::string& name);
  // Glob on names ("*" any run of characters); empty = all. Sorted by name.
  std::vector<camus::ServiceInfo> list(const std::string& pattern) const;
  // By service name (UNKNOWN_SERVICE if none), else by interface name (NOT_FOUND if no service
  // implements it), else by message type (the first registered interface whose description
  // holds it; NOT_FOUND if none); BAD_ARGUMENTS if none is given.
  Result<camus::DescribeReply> describe(const camus::DescribeRequest& request) const;

  std::optional<Route> route(const std::string& name) const;

  // The session closed: removes what it owns (publishing "gone"); returns the removed names.
  std::vector<std::string> remove_session(uint64_t session_id);

  // SchemaLookup
  std::shared_ptr<const InterfaceSchema> schema_for_service(const std::string& service) const override;
  std::shared_ptr<const InterfaceSchema> schema_with_message(const std::string& full_name) const override;

 private:
  struct Entry {
    camus::ServiceInfo info;
    planet::SessionPtr owner;         // null for built-ins
    uint64_t owner_session = 0;       // Session::id() of the connection
    uint64_t owner_resumable = 0;     // Session::identity().session
    std::shared_ptr<const InterfaceSchema> schema;
  };
  void publish_locked(const camus::ServiceInfo& info);

  const std::string space_;
  agent::EventSink& events_;
  mutable std::mutex mutex_;
  std::map<std::string, Entry> services_;
  std::map<std::string, std::shared_ptr<const InterfaceSchema>> interfaces_;
};

// The built-in service "camus.registry": decodes Register/Unregister/List/Describe and answers.
// Runs synchronously (all operations are in memory).
class RegistryService {
 public:
  static constexpr const char* kName = "camus.registry";
  explicit RegistryService(Registry& registry) : registry_(registry) {}
  // `caller` is null for calls from inside the server (they may list and describe only).
  planet::CallResult handle(const planet::SessionPtr& caller, const planet::Request& request);

 private:
  Registry& registry_;
};

// "name is not valid: why" checks shared by the registry and the context store.
std::string service_name_problem(const std::string& name);

}  // namespace urs::camus_server
