// Diagnostic and DiagnosticCaller: a provider and a consumer of URS::Diagnostic over an RT
// service port, so that a deployment can check service-port connections end to end. The provider
// is the diagnostic service agent hosted generically (urs::corba_agent), as device agents are.

#include <spdlog/spdlog.h>

#include <atomic>
#include <mutex>

#include "Diagnostic.hh"
#include "components.hpp"
#include "urs/corba_agent/agent_component.hpp"
#include "urs/diagnostic/diagnostic_agent.hpp"
#include "urs/rtc/corba_port.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/number.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::rtc_manager {
namespace {

constexpr const char* kInterface = "URS::Diagnostic";

// While active, calls echo on the connected provider once per execution and counts the replies;
// the log says when the first reply of an activation came and, at deactivation, that
// activation's counts. Configuration, changeable at any time: `text`
// (what it echoes), `strict` (true: an execution without a provider, or whose echo fails or
// comes back different, is an error: the component goes to the Error state until reset) and
// `every` (it calls once every N executions, 1..1000). `every` is declared the way an OpenRTM-aist
// component's parameter behaves: any text is stored, and one that is no such number is not taken
// (the component keeps its value, which the set shows again), so that tools meet a component that
// accepts a value and keeps another.
class DiagnosticCallerComponent : public rtc::Component {
 public:
  explicit DiagnosticCallerComponent(std::string text)
      : Component({"DiagnosticCaller", "URS::Diagnostic consumer on a service port", "1.0.0", "URSLink", "Diagnostic"}),
        text_(std::move(text)),
        port_("diagnostic"),
        consumer_(port_.require("diagnostic", kInterface)) {}

 protected:
  RTC::ReturnCode_t handle_initialize() override {
    declare_parameter({"text", text_, {}, [this](const std::string& value) {
                         std::lock_guard lock(text_mutex_);
                         text_ = value;
                       }});
    declare_parameter({"strict", strict_ ? "true" : "false",
                       [](const std::string& value) {
                         return value == "true" || value == "false" ? "" : "'" + value + "' is not true or false";
                       },
                       [this](const std::string& value) { strict_ = value == "true"; }});
    declare_parameter({"every", "1", {}, [this](const std::string& value) {
                         double every = 0;
                         const std::string why = util::read_number(value, 1, 1000, every);
                         if (!why.empty() || every != static_cast<double>(static_cast<int>(every))) {
                           throw rtc::ValueNotTaken(why.empty() ? "'" + value + "' is not a whole number" : why);
                         }
                         every_ = static_cast<int>(every);
                       }});
    add_port(port_);
    return RTC::RTC_OK;
  }

  RTC::ReturnCode_t handle_execute(RTC::ExecutionContextHandle_t) override {
    if (executions_++ % static_cast<std::uint64_t>(every_.load()) != 0) return RTC::RTC_OK;
    URS::Diagnostic_var provider = consumer_.get<URS::Diagnostic>();
    if (CORBA::is_nil(provider)) {
      if (!strict_) return RTC::RTC_OK;  // not connected yet
      spdlog::warn("{}: strict, and no provider is connected", instance_name());
      return RTC::RTC_ERROR;
    }
    std::string text;
    {
      std::lock_guard lock(text_mutex_);
      text = text_;
    }
    try {
      CORBA::String_var reply = provider->echo(text.c_str());
      if (text == reply.in()) {
        // The connection works: tests wait for this line rather than for a while.
        if (replies_++ == 0) spdlog::info("{}: first echo reply", instance_name());
        return RTC::RTC_OK;
      }
      ++failures_;
    } catch (const CORBA::Exception& e) {
      if (failures_++ == 0) spdlog::warn("{}: echo failed: {}", instance_name(), rtc::describe(e));
    }
    return strict_ ? RTC::RTC_ERROR : RTC::RTC_OK;
  }

  RTC::ReturnCode_t handle_activated(RTC::ExecutionContextHandle_t) override {
    replies_ = 0;
    failures_ = 0;
    return RTC::RTC_OK;
  }

  RTC::ReturnCode_t handle_deactivated(RTC::ExecutionContextHandle_t) override {
    spdlog::info("{}: {} echo replies, {} failures", instance_name(), replies_.load(), failures_.load());
    return RTC::RTC_OK;
  }

 private:
  std::mutex text_mutex_;
  std::string text_;  // guarded by text_mutex_ (tools change it from ORB threads)
  std::atomic<bool> strict_{false};
  std::atomic<int> every_{1};     // calls once every `every_` executions
  std::uint64_t executions_ = 0;  // the execution context's thread only
  rtc::CorbaPort port_;
  rtc::Consumer& consumer_;
  std::atomic<std::uint64_t> replies_{0};
  std::atomic<std::uint64_t> failures_{0};
};

}  // namespace

rtc::ComponentFactory diagnostic_factory(call::CallRecorder* calls) {
  const auto make_agent = [](const YAML::Node& params) {
    if (params && !params.IsNull()) throw util::ConfigError("config.params: Diagnostic takes no parameters");
    return std::make_shared<diagnostic::DiagnosticAgent>();
  };
  return corba_agent::agent_component_factory("Diagnostic", make_agent, calls);
}

std::unique_ptr<rtc::Component> make_diagnostic_caller(const YAML::Node& config, const rtc::ComponentEnv&) {
  std::string text = "ping";
  std::vector<std::string> errors;
  if (config) {
    util::check_keys(config, "config", {"text"}, errors);
    if (config["text"]) util::read_scalar(config["text"], "config.text", text, errors);
  }
  if (!errors.empty()) throw util::ConfigError(errors.front());
  return std::make_unique<DiagnosticCallerComponent>(text);
}

}  // namespace urs::rtc_manager
