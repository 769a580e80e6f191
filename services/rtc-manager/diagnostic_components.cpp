// Diagnostic and DiagnosticCaller: a provider and a consumer of URS::Diagnostic over an RT
// service port, so that a deployment can check service-port connections end to end. The provider
// is the diagnostic service agent hosted generically (urs::corba_agent), as device agents are.

#include <spdlog/spdlog.h>

#include <atomic>

#include "Diagnostic.hh"
#include "components.hpp"
#include "urs/corba_agent/agent_component.hpp"
#include "urs/diagnostic/diagnostic_agent.hpp"
#include "urs/rtc/corba_port.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::rtc_manager {
namespace {

constexpr const char* kInterface = "URS::Diagnostic";

// While active, calls echo on the connected provider once per execution and counts the replies;
// the counts appear in the log at deactivation.
class DiagnosticCallerComponent : public rtc::Component {
 public:
  explicit DiagnosticCallerComponent(std::string text)
      : Component({"DiagnosticCaller", "URS::Diagnostic consumer on a service port", "1.0.0", "URSLink",
                   "Diagnostic"}),
        text_(std::move(text)),
        port_("diagnostic"),
        consumer_(port_.require("diagnostic", kInterface)) {}

 protected:
  RTC::ReturnCode_t handle_initialize() override {
    declare_parameter("text", text_);
    add_port(port_);
    return RTC::RTC_OK;
  }

  RTC::ReturnCode_t handle_execute(RTC::ExecutionContextHandle_t) override {
    URS::Diagnostic_var provider = consumer_.get<URS::Diagnostic>();
    if (CORBA::is_nil(provider)) return RTC::RTC_OK;  // not connected yet
    try {
      CORBA::String_var reply = provider->echo(text_.c_str());
      if (text_ == reply.in()) {
        ++replies_;
      } else {
        ++failures_;
      }
    } catch (const CORBA::Exception& e) {
      if (failures_++ == 0) spdlog::warn("{}: echo failed: {}", instance_name(), rtc::describe(e));
    }
    return RTC::RTC_OK;
  }

  RTC::ReturnCode_t handle_deactivated(RTC::ExecutionContextHandle_t) override {
    spdlog::info("{}: {} echo replies, {} failures", instance_name(), replies_.load(), failures_.load());
    return RTC::RTC_OK;
  }

 private:
  const std::string text_;
  rtc::CorbaPort port_;
  rtc::Consumer& consumer_;
  std::atomic<std::uint64_t> replies_{0};
  std::atomic<std::uint64_t> failures_{0};
};

}  // namespace

std::unique_ptr<rtc::Component> make_diagnostic(const YAML::Node& config, const rtc::ComponentEnv& env) {
  const auto make_agent = [](const YAML::Node& params) {
    if (params && !params.IsNull()) throw util::ConfigError("config.params: Diagnostic takes no parameters");
    return std::make_shared<diagnostic::DiagnosticAgent>();
  };
  return corba_agent::agent_component_factory("Diagnostic", make_agent)(config, env);
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
