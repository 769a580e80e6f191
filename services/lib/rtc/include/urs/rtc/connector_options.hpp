#pragma once
// What a Connector (urs/rtc/connector.hpp) is told: its rules, its periods, its name and what it
// does on stop, and reading them from YAML (the configuration of urs-rtc-manager's connector RTC).

#include <yaml-cpp/yaml.h>

#include <chrono>
#include <string>
#include <vector>

namespace urs::rtc {

struct ConnectorRule {
  std::string interface;        // PortInterfaceProfile type_name, e.g. "URS::Diagnostic"
  std::string consumers = "*";  // glob (fnmatch, '*' also crosses '/') on consumers' naming paths
  std::string providers = "*";  // glob on providers' naming paths
};

struct ConnectorOptions {
  std::vector<ConnectorRule> rules;
  std::chrono::milliseconds poll_period{200};
  // Bound on one liveness probe; opening a new TCP connection may take the ORB's connect
  // timeout instead (omniORB applies clientConnectTimeOutPeriod to such calls).
  std::chrono::milliseconds probe_timeout{500};
  // How soon a binding whose object did not answer is read again (if it is not rebound first).
  std::chrono::milliseconds retry_period{2000};
  // The connector profile name of connections this connector makes; they also carry the
  // property urslink.connector=<name>, which is how a later connector of the same name
  // recognises them as its own.
  std::string name = "urs-connector";
  // On stop(): false leaves connections in place (consumers keep working and a connector
  // started later adopts them); true disconnects the ones this connector made.
  bool disconnect_on_stop = false;
};

// Reads the options from a YAML map:
//   poll_ms: 200              probe_timeout_ms: 500       retry_ms: 2000
//   name: Connector0          on_stop: keep | disconnect
//   rules: [{interface: URS::Diagnostic, consumers: "*.host_cxt/DiagnosticCaller*.rtc", providers: "*"}]
// `rules` is required; the rest default as above (name: `default_name`). Throws
// urs::util::ConfigError listing every mistake.
ConnectorOptions connector_options_from_yaml(const YAML::Node& node, const std::string& default_name);

}  // namespace urs::rtc
