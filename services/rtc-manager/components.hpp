#pragma once
// The component types urs-rtc-manager can create (its catalog). Each factory (an
// rtc::ComponentFactory) takes the component's `config:` node from the manager's configuration
// (may be null) and what the manager offers (ORB, naming client, options), and throws
// urs::util::ConfigError for a bad value. Device components join the catalog from devices/.

#include <yaml-cpp/yaml.h>

#include <memory>

#include "urs/call/recorder.hpp"
#include "urs/rtc/component.hpp"
#include "urs/rtc/manager.hpp"

namespace urs::rtc_manager {

// Diagnostic: the diagnostic service agent hosted generically (urs::corba_agent): provider port
// "diagnostic" offering URS::Diagnostic (instance "diagnostic"); config keys as for any hosted agent.
// Its calls are counted in `calls` when given (metrics).
rtc::ComponentFactory diagnostic_factory(call::CallRecorder* calls);
// DiagnosticCaller: consumer port "diagnostic" requiring URS::Diagnostic (instance "diagnostic");
// while active it calls echo at its rate and counts the replies.
std::unique_ptr<rtc::Component> make_diagnostic_caller(const YAML::Node& config, const rtc::ComponentEnv& env);
// Counter: out ports "count" (RTC::TimedLong, +1 per execution while active) and "pose"
// (RTC::TimedPose2D on a circle).
std::unique_ptr<rtc::Component> make_counter(const YAML::Node& config, const rtc::ComponentEnv& env);
// Sink: in ports "count" (RTC::TimedLong) and "pose" (RTC::TimedPose2D); logs what arrives.
std::unique_ptr<rtc::Component> make_sink(const YAML::Node& config, const rtc::ComponentEnv& env);
// Connector: watches the naming service and connects provider ports to the consumer ports that
// need their interface, by the rules in its config.
std::unique_ptr<rtc::Component> make_connector(const YAML::Node& config, const rtc::ComponentEnv& env);

}  // namespace urs::rtc_manager
