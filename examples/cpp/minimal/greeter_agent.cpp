#include "greeter_agent.hpp"

#include <memory>

#include "Greeter.pb.h"

namespace example {

using urs::agent::CallContext;
using urs::agent::Outcome;

GreeterAgent::GreeterAgent() : TypedAgent(*Example::Greeter_greet_Request::descriptor()->file(), "Greeter") {
  on<Example::Greeter_greet_Request, Example::Greeter_greet_Reply>(
      "greet", [this](const auto& request, auto& reply, const CallContext&) {
        if (request.name().empty()) {
          auto refusal = std::make_shared<Example::EmptyName>();
          refusal->set_reason("give a name to greet");
          return Outcome::raise(refusal, "empty name");
        }
        ++greetings_;
        reply.set_result("Hello, " + request.name());
        return Outcome::ok();
      });
  on<Example::Greeter_count_Request, Example::Greeter_count_Reply>(
      "count", [this](const auto&, auto& reply, const CallContext&) {
        reply.set_result(greetings_.load());
        return Outcome::ok();
      });
  check_complete();
}

}  // namespace example
