#pragma once
// The service registry: which service names exist in the space, who provides them and what
// their interface looks like.
//
// Rules:
//  - Sessions whose credential has role SAM or OPERATOR register services; the server fills owner
//    (the session's authenticated identity), peer_name (its declared name, for display) and state
//    "available" and publishes "registry/<name>" (ServiceInfo, with `change` and the providers).
//  - A service has one or more providers: the sessions that registered it. Another session of
//    the same credential (a replica of the SAM or bridge that holds it) registering the same
//    interface becomes one more provider ("provider-added"); a session of any other credential,
//    whatever its role, is refused ALREADY_EXISTS "service X is provided by Y; ...", and so is a
//    registration of another interface, or of another description of it, while another
//    provider holds the name. The credential, not a role, is who the operator trusted with
//    the service's calls: nobody without it can take a share of them.
//  - The same connection, or a connection that resumed the same session (planet::Identity::session,
//    proven by the server-issued session secret), replaces its own registration ("updated").
//  - When a provider's session closes or it unregisters, it leaves the service
//    ("provider-removed"); the last one leaving removes the service, published with state "gone"
//    ("unregistered" / "disconnected"). Built-in services (owner "camus-server") cannot be replaced
//    or removed.
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

// One session providing a service, as a route names it.
struct RouteProvider {
  planet::SessionPtr session;
  std::string name;  // the session's authenticated identity
};

// Where a call to a service goes.
struct Route {
  bool builtin = false;
  std::vector<RouteProvider> providers;  // longest registered first (empty for built-ins)
  uint32_t deadline_ms = 0;              // the service's default deadline (0 = none)
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
  // Removes the session as a provider of `name`. UNKNOWN_SERVICE if there is no such service;
  // PERMISSION_DENIED if the session does not provide it.
  Result<Done> unregister_service(const planet::Session& session, const std::string& name);
  // Glob on names ("*" any run of characters); empty = all. Sorted by name.
  std::vector<camus::ServiceInfo> list(const std::string& pattern) const;
  // By service name (UNKNOWN_SERVICE if none), else by interface name (NOT_FOUND if no service
  // implements it), else by message type (the first registered interface whose description
  // holds it; NOT_FOUND if none); BAD_ARGUMENTS if none is given.
  Result<camus::DescribeReply> describe(const camus::DescribeRequest& request) const;

  std::optional<Route> route(const std::string& name) const;

  // The session closed: it leaves every service it provides; returns the names of the services
  // it was the last provider of (removed, published "gone").
  std::vector<std::string> remove_session(uint64_t session_id);

  // SchemaLookup
  std::shared_ptr<const InterfaceSchema> schema_for_service(const std::string& service) const override;
  std::shared_ptr<const InterfaceSchema> schema_with_message(const std::string& full_name) const override;

 private:
  struct Provider {
    planet::SessionPtr session;
    uint64_t connection = 0;  // Session::id()
    uint64_t resumable = 0;   // Session::identity().session
    camus::ProviderInfo info;
  };
  struct Entry {
    camus::ServiceInfo info;          // the service as listed: the first provider's registration
    std::vector<Provider> providers;  // longest registered first; empty for built-ins
    std::shared_ptr<const InterfaceSchema> schema;
    bool builtin() const { return providers.empty(); }
    // The provider that `session` is (the same connection, or one that resumed its session).
    std::vector<Provider>::iterator find(const planet::Session& session);
  };
  // `entry.info` from its first provider and the providers' list.
  static void refresh_locked(Entry& entry);
  // Publishes registry/<name>: the service as it is now (state `state`), what changed and for whom.
  void publish_locked(const Entry& entry, const std::string& state, const std::string& change,
                      const camus::ProviderInfo& provider);
  // `provider` leaves the service at `it` (why: "provider-removed" or, if it was the last one,
  // `last_change`); returns whether the service is gone.
  bool remove_provider_locked(std::map<std::string, Entry>::iterator it, std::vector<Provider>::iterator provider,
                              const std::string& last_change);

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
