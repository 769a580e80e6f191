#include "urs/bridge/sides.hpp"

#include <cctype>

#include "urs/bridge/camus/camus_side.hpp"
#include "urs/bridge/dds/dds_side.hpp"
#include "urs/bridge/rt/rt_side.hpp"
#include "urs/util/error.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::bridge {

namespace {

constexpr auto kRetryPeriod = std::chrono::milliseconds(2000);  // a stand-in its side refused
constexpr auto kServiceRetryPeriod = std::chrono::seconds(10);  // an RTC or agent for another side's service

std::string file_safe(const std::string& text) {
  std::string out = text;
  for (char& c : out) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') c = '_';
  }
  return out;
}

// The rules of each direction, as the core takes them.
std::vector<core::RouteRule> provider_rules(const BridgeConfig& config) {
  std::vector<core::RouteRule> rules;
  for (const auto& provider : config.providers) {
    rules.push_back({{provider.match}, {}, provider.interface, provider.name, provider.deadline_ms});
  }
  // Whatever else is connected to the providers port (`urs rtc con`, rtcon) is offered too.
  rules.push_back({{"*"}, {}, "*", ProviderRule{}.name, ProviderRule{}.deadline_ms});
  return rules;
}

std::vector<core::RouteRule> service_rules(const BridgeConfig& config) {
  std::vector<core::RouteRule> rules;
  for (const auto& service : config.services) {
    rules.push_back({{service.match}, {}, "*", service.instance, service.deadline_ms});
  }
  return rules;
}

core::RouteRule import_rule(const DdsConfig& dds, const std::string& name) {
  return {dds.import_allow, dds.import_deny, "*", name, dds.deadline_ms};
}

}  // namespace

Composition compose(const BridgeConfig& config, const SideResources& resources) {
  const bool rt = resources.manager != nullptr;
  const bool camus = resources.planet.has_value();
  const bool dds = config.dds.enabled;
  if (rt && (resources.orb == nullptr || resources.naming == nullptr)) {
    throw std::logic_error("bridge: an RT side needs an ORB, a naming client and a manager");
  }
  std::vector<std::string> errors;
  if (!rt && !config.data_to_camus.empty()) errors.push_back("data_to_camus: needs a naming service (--naming)");
  if (!rt && !config.events_to_rt.empty()) errors.push_back("events_to_rt: needs a naming service (--naming)");
  if (!camus && !config.events_to_rt.empty()) errors.push_back("events_to_rt: needs a CAMUS server (--server)");
  if (!camus && !config.data_to_camus.empty()) errors.push_back("data_to_camus: needs a CAMUS server (--server)");
  util::throw_if_errors(errors, "bridge configuration");

  Composition out;
  core::BridgeLayout& layout = out.layout;
  if (rt) {
    RtSideConfig side;
    side.bridge = config.name;
    side.instance = config.instance;
    side.activate = config.activate;
    if (!config.data_dir.empty()) {
      side.connections_file = config.data_dir + "/connections-" + file_safe(config.name) + ".yaml";
    }
    for (const auto& provider : config.providers) side.providers.push_back({provider.match, provider.interface});
    for (const auto& entry : config.data_to_camus) side.in.push_back({entry.match, entry.port, entry.type});
    for (const auto& entry : config.events_to_rt) side.out.push_back({entry.match, entry.port, entry.type});
    side.poll = config.rt_poll;
    side.state_period = config.dds.state.period;
    out.sides.push_back(std::make_unique<RtSide>(*resources.orb, *resources.naming, *resources.manager,
                                                 resources.catalog, std::move(side)));
  }
  if (camus) {
    CamusSideConfig side;
    side.bridge = config.name;
    side.workers = config.workers;
    side.queue = config.queue;
    for (const auto& entry : config.data_to_camus) side.publish.push_back({entry.topic, entry.context});
    for (const auto& entry : config.events_to_rt) side.subscribe.push_back({entry.topic, entry.type});
    side.share_agents = dds && config.dds.state.components;
    side.share_events = config.dds.state.events;
    side.share_context_allow = config.dds.state.context_allow;
    side.share_context_deny = config.dds.state.context_deny;
    side.import_state = dds && config.dds.state.import;
    out.sides.push_back(std::make_unique<CamusSide>(std::move(side), resources.catalog, *resources.planet));
  }
  if (dds) {
    DdsSideConfig side;
    side.space = config.space;
    side.bridge = config.name;
    side.link = config.dds.link;
    side.security_pki = config.dds.security_pki;
    side.callers = config.dds.callers;
    side.audit = config.dds.audit;
    side.poses = config.dds.state.poses;
    side.hold_lost = config.dds.hold_lost;
    side.rejoin_unmet = config.dds.rejoin_unmet;
    side.workers = config.workers;
    side.queue = config.queue;
    out.sides.push_back(std::make_unique<DdsSide>(std::move(side)));
  }

  const core::NameFilter exported{config.dds.export_allow, config.dds.export_deny};
  if (rt && camus) {
    layout.directions.push_back({"rt", "camus", provider_rules(config), {}, config.rt_poll, kRetryPeriod});
    if (!config.services.empty()) {
      layout.directions.push_back({"camus", "rt", service_rules(config), {}, config.camus_poll, kServiceRetryPeriod});
    }
  }
  if (dds && camus && !config.dds.as_camus.empty()) {
    layout.directions.push_back({"dds",
                                 "camus",
                                 {import_rule(config.dds, config.dds.as_camus)},
                                 {},
                                 config.dds.link.lease,
                                 kServiceRetryPeriod});
  }
  if (dds && rt && !config.dds.as_rtc.empty()) {
    layout.directions.push_back(
        {"dds", "rt", {import_rule(config.dds, config.dds.as_rtc)}, {}, config.dds.link.lease, kServiceRetryPeriod});
  }
  if (dds && rt)
    layout.directions.push_back({"rt", "dds", provider_rules(config), exported, config.rt_poll, kRetryPeriod});
  if (dds && camus) {
    layout.directions.push_back(
        {"camus", "dds", {core::RouteRule{{"*"}, {}, "*", "{name}", 0}}, exported, config.camus_poll, kRetryPeriod});
  }
  if (dds && rt && config.dds.state.components) layout.state.push_back({"rt", "dds"});
  if (dds && camus) layout.state.push_back({"camus", "dds"});
  if (dds && camus && config.dds.state.import) layout.state.push_back({"dds", "camus"});
  if (rt && camus && !config.data_to_camus.empty()) layout.streams.push_back({"rt", "camus"});
  if (rt && camus && !config.events_to_rt.empty()) layout.streams.push_back({"camus", "rt"});
  return out;
}

}  // namespace urs::bridge
