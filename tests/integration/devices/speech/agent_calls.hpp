#pragma once
// Calls a service agent the way an agent host does (method by name, a deadline, an event sink)
// and records the events it publishes.

#include <chrono>
#include <functional>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "URCTypes.pb.h"
#include "urs/agent/agent.hpp"
#include "urs/util/cli.hpp"

namespace urs::devices::testing {

class RecordingSink : public agent::EventSink {
 public:
  call::Reply publish(const std::string& topic, const google::protobuf::Message& event) override {
    std::lock_guard lock(mutex_);
    events_.emplace_back(topic, event.SerializeAsString());
    return {};
  }
  std::vector<std::pair<std::string, std::string>> events() {
    std::lock_guard lock(mutex_);
    return events_;
  }

 private:
  std::mutex mutex_;
  std::vector<std::pair<std::string, std::string>> events_;
};

inline agent::Outcome call(agent::ServiceAgent& agent, agent::EventSink& sink, const std::string& method,
                           const google::protobuf::Message& request, google::protobuf::Message& reply,
                           std::chrono::milliseconds deadline = std::chrono::seconds(60)) {
  agent::CallContext ctx;
  ctx.service = "speech-test";
  ctx.deadline = std::chrono::steady_clock::now() + deadline;
  ctx.events = &sink;
  return agent.invoke(*agent.interface().FindMethodByName(method), request, reply, ctx);
}

// The `parameter` of a raised URC::InvalidArgument, or "" if the outcome is something else.
inline std::string invalid_parameter(const agent::Outcome& outcome) {
  const auto* error = dynamic_cast<const URC::InvalidArgument*>(outcome.exception.get());
  return error == nullptr ? "" : error->parameter();
}

// The `reason` of a raised URC::NotReady, or "" if the outcome is something else.
inline std::string not_ready_reason(const agent::Outcome& outcome) {
  const auto* error = dynamic_cast<const URC::NotReady*>(outcome.exception.get());
  return error == nullptr ? "" : error->reason();
}

// The text of the urs::util::ConfigError that `make` throws, or "" if it throws none.
inline std::string config_error_of(const std::function<void()>& make) {
  try {
    make();
  } catch (const util::ConfigError& e) {
    return e.what();
  }
  return "";
}

}  // namespace urs::devices::testing
