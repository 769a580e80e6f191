#pragma once
// Wiring between the Planet transport and the server's components:
//  - CamusSessionHandler: frames from sessions -> Router / EventBus; session close -> Registry,
//    Router and EventBus clean-up.
//  - BuiltinServices: the LocalServices of the router: "camus.registry" answered in place, every
//    other built-in handed to a ServiceContainer (the AgentHost in the executable).
//  - RouterInvoker: how task runs call services (through the router, like any caller).

#include <functional>
#include <string>

#include "urs/camus_server/event_bus.hpp"
#include "urs/camus_server/registry.hpp"
#include "urs/camus_server/router.hpp"
#include "urs/camus_server/task_manager.hpp"
#include "urs/planet/server.hpp"

namespace urs::camus_server {

// Hosts service agents inside the server (the "service container").
class ServiceContainer {
 public:
  virtual ~ServiceContainer() = default;
  virtual bool hosts(const std::string& service) const = 0;
  // Never blocks; `done` runs exactly once (on a worker thread) unless the request is oneway.
  // `caller` is who the router admitted (its authenticated identity and role).
  virtual void dispatch(const planet::Request& request, const Caller& caller, Completion done) = 0;
};

// Who may call what of the built-ins: camus.registry Register/Unregister need role SAM;
// camus.context Set/Delete and camus.tasks Define/Run/Cancel need OPERATOR; everything else
// (List, Describe, Get, Status, services in the container) CLIENT.
class BuiltinServices final : public LocalServices {
 public:
  BuiltinServices(RegistryService& registry, ServiceContainer& container)
      : registry_(registry), container_(container) {}
  bool serves(const std::string& service) const override;
  planet::Role required_role(const std::string& service, const std::string& operation) const override;
  void dispatch(const Caller& caller, const planet::Request& request, Completion done) override;

 private:
  RegistryService& registry_;
  ServiceContainer& container_;
};

class RouterInvoker final : public Invoker {
 public:
  explicit RouterInvoker(Router& router) : router_(router) {}
  void call(const std::string& caller, planet::Request request, std::function<void(planet::CallResult)> done) override;

 private:
  Router& router_;
};

// Threading: runs on the transport's I/O threads; never blocks (all slow work is queued).
class CamusSessionHandler final : public planet::SessionHandler {
 public:
  CamusSessionHandler(Registry& registry, Router& router, EventBus& bus)
      : registry_(registry), router_(router), bus_(bus) {}

  // planet::SessionHandler
  void on_open(const planet::SessionPtr& session) override;
  void on_frame(const planet::SessionPtr& session, planet::Frame&& frame) override;
  void on_close(const planet::SessionPtr& session, const std::string& reason) override;

 private:
  Registry& registry_;
  Router& router_;
  EventBus& bus_;
};

}  // namespace urs::camus_server
