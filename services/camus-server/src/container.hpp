#pragma once
// The service container of the executable: built-in agents hosted by urs::agent::AgentHost, which
// takes neutral calls (urs/call/call.hpp): this is where the router's Planet requests become them.

#include <string>

#include "urs/agent/agent.hpp"
#include "urs/camus_server/session_handler.hpp"

namespace urs::camus_server {

class AgentHostContainer final : public ServiceContainer {
 public:
  // `space` is the server's: the space of every caller the router admits.
  AgentHostContainer(agent::AgentHost& host, std::string space) : host_(host), space_(std::move(space)) {}
  bool hosts(const std::string& service) const override { return host_.find(service) != nullptr; }
  void dispatch(const planet::Request& request, const Caller& caller, Completion done) override;

 private:
  agent::AgentHost& host_;
  std::string space_;
};

}  // namespace urs::camus_server
