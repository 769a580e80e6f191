// Diagnostic and DiagnosticCaller: a provider and a consumer of URS::Diagnostic over an RT
// service port, so that a deployment can check service-port connections end to end.

#include <spdlog/spdlog.h>

#include <atomic>
#include <thread>

#include "Diagnostic.hh"
#include "components.hpp"
#include "urs/diagnostic/diagnostic.hpp"
#include "urs/rtc/corba_port.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::rtc_manager {
namespace {

constexpr const char* kInterface = "URS::Diagnostic";

class DiagnosticServant : public virtual POA_URS::Diagnostic {
 public:
  explicit DiagnosticServant(std::string owner) : owner_(std::move(owner)) {}

  char* echo(const char* text) override { return CORBA::string_dup(text); }
  CORBA::Double add(CORBA::Double a, CORBA::Double b) override { return a + b; }

  void sleep(CORBA::ULong ms) override {
    if (auto refused = diagnostic::check_sleep(ms)) throw CORBA::BAD_PARAM(0, CORBA::COMPLETED_NO);
    std::this_thread::sleep_for(std::chrono::milliseconds(ms));
  }

  URS::OctetSeq* blob(CORBA::ULong size) override {
    if (auto refused = diagnostic::check_blob(size)) throw CORBA::BAD_PARAM(0, CORBA::COMPLETED_NO);
    const std::string bytes = diagnostic::patterned_bytes(size);
    auto* out = new URS::OctetSeq(size);
    out->length(size);
    std::copy(bytes.begin(), bytes.end(), out->get_buffer());
    return out;
  }

  CORBA::ULongLong checksum(const URS::OctetSeq& data) override {
    return diagnostic::fnv1a64(data.get_buffer(), data.length());
  }

  void fail(const char* reason, CORBA::Long code) override { throw URS::Failure(reason, code); }

  // The RT side has no event system: the notification is logged.
  void notify(const char* topic, const char* text) override {
    spdlog::info("{}: notify {}: {}", owner_, topic, text);
  }

 private:
  const std::string owner_;
};

class DiagnosticComponent : public rtc::Component {
 public:
  DiagnosticComponent()
      : Component({"Diagnostic", "URS::Diagnostic provider on a service port", "1.0.0", "URSLink", "Diagnostic"}),
        port_("diagnostic") {}

 protected:
  RTC::ReturnCode_t handle_initialize() override {
    servant_ = std::make_unique<DiagnosticServant>(instance_name());
    port_.provide("diagnostic", kInterface, *servant_);
    add_port(port_);
    return RTC::RTC_OK;
  }

 private:
  std::unique_ptr<DiagnosticServant> servant_;  // outlives port_: declared first, destroyed last
  rtc::CorbaPort port_;
};

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

std::unique_ptr<rtc::Component> make_diagnostic(const YAML::Node& config, const rtc::ComponentEnv&) {
  if (config && !config.IsNull() && !(config.IsMap() && config.size() == 0)) {
    throw util::ConfigError("Diagnostic takes no config");
  }
  return std::make_unique<DiagnosticComponent>();
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
