#include "urs/camus_server/tasks_agent.hpp"

#include "urs/camus_server/agent_util.hpp"

namespace urs::camus_server {

namespace gp = google::protobuf;

const gp::ServiceDescriptor& TasksAgent::interface() const {
  return *camus::TaskRun::descriptor()->file()->FindServiceByName("Tasks");
}

agent::Outcome TasksAgent::invoke(const gp::MethodDescriptor& method, const gp::Message& request, gp::Message& reply,
                                  const agent::CallContext& ctx) {
  const std::string& op = method.name();
  auto answer = [&reply](const auto& result) {
    if (!result.ok()) return refused(result);
    fill_reply(reply, result.value());
    return agent::Outcome::ok();
  };
  if (op == "Define") {
    camus::TaskDefinition storage;
    const auto& in = message_as(request, storage);
    auto defined = manager_.define(in.name(), in.yaml(), ctx.caller.name);
    if (!defined.ok()) return refused(defined);
    camus::TaskDefineReply out;
    *out.mutable_task() = defined.value();
    fill_reply(reply, out);
    return agent::Outcome::ok();
  }
  if (op == "Run") {
    camus::TaskRunRequest storage;
    return answer(manager_.run(message_as(request, storage), ctx.caller.known() ? "call:" + ctx.caller.name : "call",
                               ctx.caller.name));
  }
  if (op == "Status") {
    camus::TaskStatusRequest storage;
    return answer(manager_.status(message_as(request, storage)));
  }
  if (op == "Cancel") {
    camus::TaskCancelRequest storage;
    return answer(manager_.cancel(message_as(request, storage).run_id(), ctx.caller.name));
  }
  if (op == "List") {
    fill_reply(reply, manager_.list());
    return agent::Outcome::ok();
  }
  return agent::Outcome::error(call::Status::UNKNOWN_OPERATION,
                               "interface urs.camus.Tasks has no operation '" + op + "'");
}

}  // namespace urs::camus_server
