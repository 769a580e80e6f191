#pragma once
// Every device service, by the type name configurations use. A device is written once as a
// service agent; urs-sam hosts it as a CAMUS service agent and urs-rtc-manager as an
// RT-Component (generic hosting, services/lib/corba_agent), from configuration alone.

#include <yaml-cpp/yaml.h>

#include <functional>
#include <map>
#include <memory>
#include <string>

#include "urs/agent/agent.hpp"

namespace urs::devices {

// Builds the device's agent from its `params:` node (may be null); throws urs::util::ConfigError
// naming the bad key.
using AgentFactory = std::function<std::shared_ptr<agent::ServiceAgent>(const YAML::Node& params)>;

struct DeviceType {
  AgentFactory make;
  std::string component_type;  // the RT-Component type name in urs-rtc-manager's catalog
};

// "robot", "localizer", "tts", "voice", "camera".
const std::map<std::string, DeviceType>& catalog();

}  // namespace urs::devices
