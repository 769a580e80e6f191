#include "urs/rtc/connector_options.hpp"

#include <string>
#include <utility>
#include <vector>

#include "urs/util/yaml_config.hpp"

namespace urs::rtc {

ConnectorOptions connector_options_from_yaml(const YAML::Node& node, const std::string& default_name) {
  ConnectorOptions options;
  options.name = default_name;
  std::vector<std::string> errors;
  auto read_ms = [&](const char* key, long min, std::chrono::milliseconds& out) {
    long value = 0;
    if (!node[key] || !util::read_scalar(node[key], key, value, errors)) return;
    if (value < min) {
      errors.push_back(std::string(key) + ": " + std::to_string(value) + " is below " + std::to_string(min));
    } else {
      out = std::chrono::milliseconds(value);
    }
  };
  if (!node || node.IsNull() || !node.IsMap()) {
    errors.push_back("a map with a 'rules' list is required");
  } else {
    util::check_keys(node, "", {"poll_ms", "probe_timeout_ms", "retry_ms", "name", "on_stop", "rules"}, errors);
    read_ms("poll_ms", 10, options.poll_period);
    read_ms("probe_timeout_ms", 1, options.probe_timeout);
    read_ms("retry_ms", 0, options.retry_period);
    if (node["name"] && util::read_scalar(node["name"], "name", options.name, errors) && options.name.empty()) {
      errors.push_back("name: must not be empty");
    }
    std::string on_stop = "keep";
    if (node["on_stop"] && util::read_scalar(node["on_stop"], "on_stop", on_stop, errors)) {
      if (on_stop != "keep" && on_stop != "disconnect") {
        errors.push_back("on_stop: '" + on_stop + "' is not keep or disconnect");
      }
      options.disconnect_on_stop = on_stop == "disconnect";
    }
    const YAML::Node rules = node["rules"];
    if (!rules || !rules.IsSequence() || rules.size() == 0) {
      errors.push_back("rules: a non-empty list of {interface, consumers, providers} is required");
    } else {
      util::for_each_map(rules, "rules", "interface, consumers and providers", {"interface", "consumers", "providers"},
                         errors, [&](const YAML::Node& r, const std::string& where) {
                           ConnectorRule rule;
                           if (!r["interface"]) {
                             errors.push_back(where + ".interface: missing");
                           } else if (util::read_scalar(r["interface"], where + ".interface", rule.interface, errors) &&
                                      rule.interface.empty()) {
                             errors.push_back(where + ".interface: must not be empty");
                           }
                           if (r["consumers"])
                             util::read_scalar(r["consumers"], where + ".consumers", rule.consumers, errors);
                           if (r["providers"])
                             util::read_scalar(r["providers"], where + ".providers", rule.providers, errors);
                           options.rules.push_back(std::move(rule));
                         });
    }
  }
  util::throw_if_errors(errors, "connector configuration");
  return options;
}

}  // namespace urs::rtc
