#pragma once
// The service container of the executable: built-in agents hosted by urs::agent::AgentHost.

#include "urs/agent/agent.hpp"
#include "urs/camus_server/session_handler.hpp"

namespace urs::camus_server {

class AgentHostContainer final : public ServiceContainer {
 public:
  explicit AgentHostContainer(agent::AgentHost& host) : host_(host) {}
  bool hosts(const std::string& service) const override { return host_.find(service) != nullptr; }
  void dispatch(const planet::Request& request, const std::string& caller, Completion done) override;

 private:
  agent::AgentHost& host_;
};

}  // namespace urs::camus_server
