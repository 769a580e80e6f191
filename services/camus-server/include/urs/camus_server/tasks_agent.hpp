#pragma once
// The task manager as a service of the space.

#include "urs/agent/agent.hpp"
#include "urs/camus_server/task_manager.hpp"

namespace urs::camus_server {

// The built-in service "camus.tasks" (urs.camus.Tasks) for the service container.
class TasksAgent final : public agent::ServiceAgent {
 public:
  static constexpr const char* kName = "camus.tasks";
  explicit TasksAgent(TaskManager& manager) : manager_(manager) {}
  const google::protobuf::ServiceDescriptor& interface() const override;
  agent::Outcome invoke(const google::protobuf::MethodDescriptor& method, const google::protobuf::Message& request,
                        google::protobuf::Message& reply, const agent::CallContext& ctx) override;

 private:
  TaskManager& manager_;
};

}  // namespace urs::camus_server
