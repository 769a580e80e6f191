// The Calculator plug-in: one agent type, "calculator" (RT-Component type "Calculator"), serving
// PluginExample::Calculator. urs-sam and urs-rtc-manager load it from their `plugins:` list.
//
//   agents:                       # urs-sam
//     - name: calc
//       type: calculator
//       params: {label: lab-calculator}

#include <atomic>
#include <memory>
#include <string>

#include "Calculator.pb.h"
#include "urs/agent/plugin.hpp"
#include "urs/agent/typed_agent.hpp"

namespace {

using urs::agent::CallContext;
using urs::agent::Outcome;

// Calls run on the host's worker threads: the counter is atomic.
class CalculatorAgent : public urs::agent::TypedAgent {
 public:
  explicit CalculatorAgent(std::string label)
      : TypedAgent(*PluginExample::Calculator_divide_Request::descriptor()->file(), "Calculator"),
        label_(std::move(label)) {
    on<PluginExample::Calculator_divide_Request, PluginExample::Calculator_divide_Reply>(
        "divide", [this](const auto& request, auto& reply, const CallContext&) {
          if (request.divisor() == 0.0) {
            auto refusal = std::make_shared<PluginExample::DivisionByZero>();
            refusal->set_dividend(request.dividend());
            return Outcome::raise(refusal, "division by zero");
          }
          ++calls_;
          reply.set_result(request.dividend() / request.divisor());
          return Outcome::ok();
        });
    on<PluginExample::Calculator_calls_Request, PluginExample::Calculator_calls_Reply>(
        "calls", [this](const auto&, auto& reply, const CallContext&) {
          reply.set_result(calls_.load());
          return Outcome::ok();
        });
    on<PluginExample::Calculator_label_Request, PluginExample::Calculator_label_Reply>(
        "label", [this](const auto&, auto& reply, const CallContext&) {
          reply.set_result(label_);
          return Outcome::ok();
        });
    check_complete();
  }

 private:
  const std::string label_;
  std::atomic<unsigned> calls_{0};
};

}  // namespace

URS_PLUGIN_ABI();

extern "C" URS_PLUGIN_EXPORT int urs_plugin_register(urs::agent::PluginRegistry& registry) {
  registry.add({"calculator", "Calculator",
                [](const YAML::Node& params) {
                  // A bad value throws YAML's exception naming it: the host refuses the entry with it.
                  const std::string label =
                      params && params["label"] ? params["label"].as<std::string>() : "calculator";
                  return std::make_shared<CalculatorAgent>(label);
                },
                "PluginExample::Calculator: divide, calls, label"});
  return 0;
}
