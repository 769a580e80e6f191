// Connector: an RT-Component wrapping urs::rtc::Connector. Activation starts the watcher on a
// thread of its own (the execution context only switches it on and off); deactivation stops it
// and, unless `on_stop: disconnect` is configured, leaves the connections it made in place: they
// work without the connector, and a connector activated later finds and adopts them.

#include <spdlog/spdlog.h>

#include <memory>
#include <utility>

#include "components.hpp"
#include "urs/rtc/connector.hpp"
#include "urs/rtc/naming.hpp"

namespace urs::rtc_manager {
namespace {

class ConnectorComponent : public rtc::Component {
 public:
  ConnectorComponent(YAML::Node config, rtc::Orb& orb, std::string naming_address)
      : rtc::Component({"Connector", "Connects service ports found in the naming service, by rules", "1.0.0", "URSLink",
                        "Utility"}),
        config_(std::move(config)),
        orb_(orb),
        naming_address_(std::move(naming_address)) {
    // Checked now, so that a bad configuration stops the manager at start-up; the connector is
    // named after the instance, which is known only once the component is set up.
    rtc::connector_options_from_yaml(config_, "Connector");
  }

 protected:
  RTC::ReturnCode_t handle_activated(RTC::ExecutionContextHandle_t) override {
    connector_ = std::make_unique<rtc::Connector>(orb_, naming_address_,
                                                  rtc::connector_options_from_yaml(config_, instance_name()));
    connector_->start();
    const auto& options = connector_->options();
    spdlog::info("{}: watching naming service {} every {} ms, {} rule(s)", instance_name(), naming_address_,
                 options.poll_period.count(), options.rules.size());
    return RTC::RTC_OK;
  }

  RTC::ReturnCode_t handle_deactivated(RTC::ExecutionContextHandle_t) override {
    stop();
    return RTC::RTC_OK;
  }

  RTC::ReturnCode_t handle_finalize() override {
    stop();
    return RTC::RTC_OK;
  }

 private:
  void stop() {
    if (!connector_) return;
    connector_->stop();
    connector_.reset();
    spdlog::info("{}: stopped watching", instance_name());
  }

  const YAML::Node config_;
  rtc::Orb& orb_;
  const std::string naming_address_;
  std::unique_ptr<rtc::Connector> connector_;
};

}  // namespace

std::unique_ptr<rtc::Component> make_connector(const YAML::Node& config, const rtc::ComponentEnv& env) {
  return std::make_unique<ConnectorComponent>(config, env.orb, env.naming.address());
}

}  // namespace urs::rtc_manager
