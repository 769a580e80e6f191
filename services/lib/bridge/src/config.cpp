#include "urs/bridge/config.hpp"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <netinet/in.h>

#include <filesystem>
#include <set>

#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::bridge {

federation::DdsOptions bridge_link_defaults() {
  federation::DdsOptions options;
  options.participant_lease = std::chrono::milliseconds(20000);
  return options;
}

namespace {

// Reads a required or optional string key of `node` into `out`.
void read_string(const YAML::Node& node, const std::string& key, const std::string& where, bool required,
                 std::string& out, std::vector<std::string>& errors) {
  if (!node[key]) {
    if (required) errors.push_back(where + "." + key + ": missing");
    return;
  }
  if (util::read_scalar(node[key], where + "." + key, out, errors) && out.empty()) {
    errors.push_back(where + "." + key + ": must not be empty");
  }
}

// Reads a period in milliseconds (10..60000) at `key` of `node`.
void read_ms(const YAML::Node& node, const std::string& key, const std::string& where, std::chrono::milliseconds& out,
             std::vector<std::string>& errors) {
  if (!node[key]) return;
  int ms = 0;
  if (!util::read_scalar(node[key], where + "." + key, ms, errors)) return;
  if (ms < 10 || ms > 60000) {
    errors.push_back(where + "." + key + ": " + std::to_string(ms) + " is outside 10..60000");
    return;
  }
  out = std::chrono::milliseconds(ms);
}

void read_deadline(const YAML::Node& node, const std::string& where, uint32_t& out, std::vector<std::string>& errors) {
  if (!node["deadline_ms"]) return;
  if (util::read_scalar(node["deadline_ms"], where + ".deadline_ms", out, errors) && out == 0) {
    errors.push_back(where + ".deadline_ms: must be > 0");
  }
}

std::vector<std::string> read_paths(const YAML::Node& node, const std::string& where, const std::string& base,
                                    std::vector<std::string>& errors) {
  std::vector<std::string> paths;
  if (!node) return paths;
  if (!node.IsSequence()) {
    errors.push_back(where + ": a list of paths is expected");
    return paths;
  }
  for (std::size_t i = 0; i < node.size(); ++i) {
    std::string path;
    if (!util::read_scalar(node[i], where + "[" + std::to_string(i) + "]", path, errors)) continue;
    std::filesystem::path p(path);
    if (p.is_relative()) p = std::filesystem::path(base) / p;
    if (!std::filesystem::exists(p)) {
      errors.push_back(where + "[" + std::to_string(i) + "]: " + p.string() + " does not exist");
      continue;
    }
    paths.push_back(p.lexically_normal().string());
  }
  return paths;
}

// The list under `key` of `section`, or an undefined node if absent; reports a non-list.
YAML::Node list_of(const YAML::Node& section, const std::string& key, const std::string& where,
                   std::vector<std::string>& errors) {
  const YAML::Node list = section[key];
  if (list && !list.IsSequence()) {
    errors.push_back((where.empty() ? key : where + "." + key) + ": a list is expected");
    return YAML::Node(YAML::NodeType::Undefined);
  }
  return list;
}

std::vector<std::string> read_strings(const YAML::Node& node, const std::string& where,
                                      std::vector<std::string>& errors) {
  std::vector<std::string> out;
  if (!node.IsSequence()) {
    errors.push_back(where + ": a list is expected");
    return out;
  }
  for (std::size_t i = 0; i < node.size(); ++i) {
    std::string item;
    if (util::read_scalar(node[i], where + "[" + std::to_string(i) + "]", item, errors)) out.push_back(item);
  }
  return out;
}

void read_filter(const YAML::Node& node, const std::string& where, std::vector<std::string>& allow,
                 std::vector<std::string>& deny, std::vector<std::string>& errors) {
  if (node["allow"]) allow = read_strings(node["allow"], where + ".allow", errors);
  if (node["deny"]) deny = read_strings(node["deny"], where + ".deny", errors);
}

void read_state(const YAML::Node& node, uint32_t link_domain, StateConfig& state, std::vector<std::string>& errors) {
  if (!node.IsMap()) {
    errors.push_back("dds.state: a map is expected");
    return;
  }
  util::check_keys(node, "dds.state", {"components", "period_ms", "poses", "events", "context", "import"}, errors);
  if (node["components"]) util::read_scalar(node["components"], "dds.state.components", state.components, errors);
  read_ms(node, "period_ms", "dds.state", state.period, errors);
  if (const YAML::Node poses = node["poses"]) {
    util::check_keys(poses, "dds.state.poses", {"domain", "source", "robots", "period_ms"}, errors);
    federation::PoseRelay relay;
    if (!poses["domain"]) {
      errors.push_back("dds.state.poses.domain: missing (the devices' DDS domain)");
    } else if (util::read_scalar(poses["domain"], "dds.state.poses.domain", relay.domain, errors) &&
               (relay.domain > 232 || relay.domain == link_domain)) {
      errors.push_back(
          "dds.state.poses.domain: " + std::to_string(relay.domain) +
          (relay.domain > 232 ? " is outside 0..232" : " is the link's domain; give the devices their own"));
    }
    std::string source = "localizer";
    if (poses["source"] && util::read_scalar(poses["source"], "dds.state.poses.source", source, errors) &&
        source != "localizer" && source != "ground_truth") {
      errors.push_back("dds.state.poses.source: '" + source + "' is neither localizer nor ground_truth");
    }
    relay.ground_truth = source == "ground_truth";
    if (poses["robots"]) relay.robots = read_strings(poses["robots"], "dds.state.poses.robots", errors);
    if (relay.robots.empty()) errors.push_back("dds.state.poses.robots: name at least one robot");
    read_ms(poses, "period_ms", "dds.state.poses", relay.period, errors);
    state.poses = relay;
  }
  if (node["events"]) state.events = read_strings(node["events"], "dds.state.events", errors);
  if (const YAML::Node context = node["context"]) {
    util::check_keys(context, "dds.state.context", {"allow", "deny"}, errors);
    read_filter(context, "dds.state.context", state.context_allow, state.context_deny, errors);
  }
  if (node["import"]) util::read_scalar(node["import"], "dds.state.import", state.import, errors);
}

// dds.export.callers: {SERVICE_GLOB: [CALLER, ...], ...} in the order written.
void read_callers(const YAML::Node& node, CallerPolicy& policy, std::vector<std::string>& errors) {
  const std::string where = "dds.export.callers";
  if (!node.IsMap()) {
    errors.push_back(where + ": a map of service globs to lists of callers is expected");
    return;
  }
  policy.enabled = true;
  for (const auto& item : node) {
    CallerRule rule;
    if (!util::read_scalar(item.first, where, rule.services, errors)) continue;
    const std::string at = where + "['" + rule.services + "']";
    if (rule.services.empty()) errors.push_back(where + ": a service glob is empty");
    if (!item.second.IsSequence()) {
      errors.push_back(at + ": a list of callers (SPACE or SPACE/NAME) is expected");
      continue;
    }
    rule.callers = read_strings(item.second, at, errors);
    for (std::size_t i = 0; i < rule.callers.size(); ++i) {
      const std::string problem = caller_pattern_problem(rule.callers[i]);
      if (!problem.empty()) errors.push_back(at + "[" + std::to_string(i) + "]: " + problem);
    }
    policy.rules.push_back(std::move(rule));
  }
}

// dds.audit: {file, max_bytes, files}; a relative file is taken from `base`.
void read_audit(const YAML::Node& node, const std::string& base, AuditConfig& audit, std::vector<std::string>& errors) {
  if (!node.IsMap()) {
    errors.push_back("dds.audit: a map with 'file' is expected");
    return;
  }
  util::check_keys(node, "dds.audit", {"file", "max_bytes", "files"}, errors);
  read_string(node, "file", "dds.audit", true, audit.file, errors);
  if (!audit.file.empty()) {
    std::filesystem::path file(audit.file);
    if (file.is_relative()) file = std::filesystem::path(base) / file;
    file = file.lexically_normal();
    audit.file = file.string();
    if (!std::filesystem::is_directory(file.parent_path())) {
      errors.push_back("dds.audit.file: the folder " + file.parent_path().string() + " does not exist");
    }
  }
  if (node["max_bytes"] && util::read_scalar(node["max_bytes"], "dds.audit.max_bytes", audit.max_bytes, errors) &&
      (audit.max_bytes < 1024 || audit.max_bytes > (std::size_t{1} << 40))) {
    errors.push_back("dds.audit.max_bytes: " + std::to_string(audit.max_bytes) + " is outside 1024..2^40");
  }
  if (node["files"] && util::read_scalar(node["files"], "dds.audit.files", audit.files, errors) &&
      (audit.files < 1 || audit.files > 1000)) {
    errors.push_back("dds.audit.files: " + std::to_string(audit.files) + " is outside 1..1000");
  }
}

// The port of "HOST:PORT" (1..65535), or 0 if `address` is no HOST:PORT.
uint16_t port_of(const std::string& address) {
  const auto colon = address.rfind(':');
  if (colon == std::string::npos || colon == 0) return 0;
  const std::string digits = address.substr(colon + 1);
  if (digits.empty() || digits.size() > 5 || digits.find_first_not_of("0123456789") != std::string::npos) return 0;
  const int port = std::stoi(digits);
  return port > 65535 ? 0 : static_cast<uint16_t>(port);
}

// Whether `text` is a dotted IPv4 address (four numbers 0..255).
bool is_ipv4(const std::string& text) {
  in_addr address{};
  return inet_pton(AF_INET, text.c_str(), &address) == 1;
}

// The IPv4 addresses of this host's interfaces, as Fast DDS 2.9 finds them (getifaddrs).
std::set<std::string> host_ipv4_addresses() {
  std::set<std::string> addresses;
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) return addresses;
  for (const ifaddrs* item = list; item != nullptr; item = item->ifa_next) {
    if (item->ifa_addr == nullptr || item->ifa_addr->sa_family != AF_INET) continue;
    char text[INET_ADDRSTRLEN] = {};
    const auto* address = reinterpret_cast<const sockaddr_in*>(item->ifa_addr);
    if (inet_ntop(AF_INET, &address->sin_addr, text, sizeof text) != nullptr) addresses.insert(text);
  }
  freeifaddrs(list);
  return addresses;
}

// dds.interfaces: IPv4 addresses of this host's interfaces, the only ones the link's UDP or TCP
// transport uses (Fast DDS 2.9's interfaceWhiteList takes addresses, not interface names, and
// silently drops one no interface has).
void read_interfaces(const YAML::Node& node, federation::DdsOptions& link, std::vector<std::string>& errors) {
  const std::string where = "dds.interfaces";
  link.interfaces = read_strings(node, where, errors);
  if (node.IsSequence() && link.interfaces.empty()) {
    errors.push_back(where + ": name at least one address, or leave the key out to use every interface");
    return;
  }
  const std::set<std::string> host = host_ipv4_addresses();
  std::string known;
  for (const auto& address : host) known += (known.empty() ? "" : ", ") + address;
  for (std::size_t i = 0; i < link.interfaces.size(); ++i) {
    const std::string& entry = link.interfaces[i];
    const std::string at = where + "[" + std::to_string(i) + "]: '" + entry + "'";
    in_addr address{};
    if (inet_pton(AF_INET, entry.c_str(), &address) != 1) {
      errors.push_back(at + " is not an IPv4 address (Fast DDS 2.9 takes an interface's address, not its name)");
    } else if (address.s_addr == htonl(INADDR_ANY)) {
      errors.push_back(at + " is no interface's address: leave dds.interfaces out to use every interface");
    } else if (host.count(entry) == 0) {
      errors.push_back(at + " is no address of this host's interfaces (" + (known.empty() ? "none found" : known) +
                       "): Fast DDS would leave the link without it");
    }
  }
}

// dds.transport (udp | tcp) and dds.tcp {listen, public, connect, rejoin_after_ms}.
void read_transport(const YAML::Node& node, DdsConfig& dds, std::vector<std::string>& errors) {
  federation::DdsOptions& link = dds.link;
  using Transport = federation::DdsOptions::Transport;
  std::string transport = "udp";
  if (node["transport"] && util::read_scalar(node["transport"], "dds.transport", transport, errors)) {
    if (transport == "tcp") {
      link.transport = Transport::kTcp;
    } else if (transport != "udp") {
      errors.push_back("dds.transport: '" + transport + "' is neither udp nor tcp");
      return;
    }
  }
  const YAML::Node tcp = node["tcp"];
  if (link.transport != Transport::kTcp) {
    if (tcp) errors.push_back("dds.tcp: only with dds.transport: tcp");
    return;
  }
  if (node["initial_peers"]) {
    errors.push_back("dds.initial_peers: UDP only; over TCP the listening sites are dds.tcp.connect");
  }
  if (node["udp_only"]) errors.push_back("dds.udp_only: has no effect with dds.transport: tcp");
  const bool has_servers = node["discovery"] && node["discovery"]["servers"];
  if (!tcp) {
    if (!has_servers) {
      errors.push_back("dds.tcp: missing: give 'listen' (this site listens) or 'connect' (the listening sites)");
    }
    return;
  }
  if (!tcp.IsMap()) {
    errors.push_back("dds.tcp: a map is expected");
    return;
  }
  util::check_keys(tcp, "dds.tcp", {"listen", "public", "connect", "rejoin_after_ms"}, errors);
  if (tcp["rejoin_after_ms"]) {
    int ms = 0;
    if (util::read_scalar(tcp["rejoin_after_ms"], "dds.tcp.rejoin_after_ms", ms, errors)) {
      if (ms != 0 && (ms < 1000 || ms > 3600000)) {
        errors.push_back("dds.tcp.rejoin_after_ms: " + std::to_string(ms) + " is neither 0 nor in 1000..3600000");
      }
      dds.rejoin_unmet = std::chrono::milliseconds(ms);
    }
  }
  if (tcp["listen"] && util::read_scalar(tcp["listen"], "dds.tcp.listen", link.tcp.listen, errors) &&
      link.tcp.listen == 0) {
    errors.push_back("dds.tcp.listen: must be a port, 1..65535");
  }
  if (tcp["public"]) {
    std::string text;
    if (util::read_scalar(tcp["public"], "dds.tcp.public", text, errors)) {
      const auto colon = text.rfind(':');
      link.tcp.public_address = text.substr(0, colon);
      if (colon != std::string::npos) link.tcp.public_port = port_of(text);
      if (!is_ipv4(link.tcp.public_address) || (colon != std::string::npos && link.tcp.public_port == 0)) {
        errors.push_back("dds.tcp.public: '" + text + "' is not IPv4[:PORT] (an address, not a name: it is announced)");
      }
    }
  }
  if (tcp["connect"]) {
    link.tcp.connect = read_strings(tcp["connect"], "dds.tcp.connect", errors);
    for (std::size_t i = 0; i < link.tcp.connect.size(); ++i) {
      if (port_of(link.tcp.connect[i]) == 0) {
        errors.push_back("dds.tcp.connect[" + std::to_string(i) + "]: '" + link.tcp.connect[i] + "' is not HOST:PORT");
      }
    }
  }
  if (link.tcp.listen != 0 && link.tcp.public_address.empty()) {
    errors.push_back(
        "dds.tcp.public: missing: a listening site must announce the address (and port) the other sites reach it at, "
        "else they discover it but match none of its endpoints");
  }
  if (link.tcp.listen == 0 && link.tcp.public_port != 0) {
    errors.push_back("dds.tcp.public: a site that does not listen announces an address only, no port");
  }
  if (link.tcp.listen == 0 && link.tcp.connect.empty() && !has_servers) {
    errors.push_back("dds.tcp: give 'listen' (this site listens) or 'connect' (the listening sites), or both");
  }
}

void read_dds(const YAML::Node& node, const std::string& base, DdsConfig& dds, std::vector<std::string>& errors) {
  dds.enabled = true;
  if (!node.IsMap()) {
    errors.push_back("dds: a map is expected");
    return;
  }
  util::check_keys(
      node, "dds",
      {"domain", "lease_ms", "participant_lease_ms", "hold_lost_ms", "udp_only", "socket_buffer_bytes", "initial_peers",
       "interfaces", "transport", "tcp", "discovery", "security", "export", "import", "state", "audit"},
      errors);
  if (node["domain"] && util::read_scalar(node["domain"], "dds.domain", dds.link.domain, errors) &&
      dds.link.domain > 232) {
    errors.push_back("dds.domain: " + std::to_string(dds.link.domain) + " is outside 0..232");
  }
  if (node["lease_ms"]) {
    int ms = 0;
    if (util::read_scalar(node["lease_ms"], "dds.lease_ms", ms, errors)) {
      if (ms < 100 || ms > 600000) errors.push_back("dds.lease_ms: " + std::to_string(ms) + " is outside 100..600000");
      dds.link.lease = std::chrono::milliseconds(ms);
    }
  }
  if (node["participant_lease_ms"]) {
    int ms = 0;
    if (util::read_scalar(node["participant_lease_ms"], "dds.participant_lease_ms", ms, errors)) {
      if (ms < 100 || ms > 600000) {
        errors.push_back("dds.participant_lease_ms: " + std::to_string(ms) + " is outside 100..600000");
      }
      dds.link.participant_lease = std::chrono::milliseconds(ms);
    }
  } else {
    dds.link.participant_lease =
        std::max(dds.link.participant_lease, dds.link.lease);  // the default, never below the lease
  }
  if (dds.link.participant_lease < dds.link.lease) {
    errors.push_back("dds.participant_lease_ms: " + std::to_string(dds.link.participant_lease.count()) +
                     " is below dds.lease_ms " + std::to_string(dds.link.lease.count()) +
                     ": a participant would be dropped while its writers still count as alive");
  }
  if (node["hold_lost_ms"]) {
    int ms = 0;
    if (util::read_scalar(node["hold_lost_ms"], "dds.hold_lost_ms", ms, errors)) {
      if (ms < 0 || ms > 3600000)
        errors.push_back("dds.hold_lost_ms: " + std::to_string(ms) + " is outside 0..3600000");
      dds.hold_lost = std::chrono::milliseconds(ms);
    }
  }
  if (node["udp_only"]) util::read_scalar(node["udp_only"], "dds.udp_only", dds.link.udp_only, errors);
  if (node["socket_buffer_bytes"]) {
    util::read_scalar(node["socket_buffer_bytes"], "dds.socket_buffer_bytes", dds.link.socket_buffer_bytes, errors);
  }
  if (node["initial_peers"]) dds.link.initial_peers = read_strings(node["initial_peers"], "dds.initial_peers", errors);
  if (node["interfaces"]) read_interfaces(node["interfaces"], dds.link, errors);
  read_transport(node, dds, errors);
  if (const YAML::Node discovery = node["discovery"]) {
    util::check_keys(discovery, "dds.discovery", {"listen", "id", "servers"}, errors);
    auto host_port = [&](const std::string& address, const std::string& where) {
      if (port_of(address) == 0) errors.push_back(where + ": '" + address + "' is not HOST:PORT");
    };
    if (discovery["listen"] &&
        util::read_scalar(discovery["listen"], "dds.discovery.listen", dds.link.discovery_listen, errors)) {
      host_port(dds.link.discovery_listen, "dds.discovery.listen");
    }
    if (discovery["id"] &&
        util::read_scalar(discovery["id"], "dds.discovery.id", dds.link.discovery_server_id, errors) &&
        dds.link.discovery_server_id > 255) {
      errors.push_back("dds.discovery.id: " + std::to_string(dds.link.discovery_server_id) + " is outside 0..255");
    }
    if (discovery["servers"]) {
      dds.link.discovery_servers = read_strings(discovery["servers"], "dds.discovery.servers", errors);
      for (std::size_t i = 0; i < dds.link.discovery_servers.size(); ++i) {
        host_port(dds.link.discovery_servers[i], "dds.discovery.servers[" + std::to_string(i) + "]");
      }
    }
    if (dds.link.discovery_listen.empty() && dds.link.discovery_servers.empty()) {
      errors.push_back("dds.discovery: give 'listen' (be the server) or 'servers' (use them)");
    }
    const uint16_t listen_port = port_of(dds.link.discovery_listen);
    if (dds.link.transport == federation::DdsOptions::Transport::kTcp && listen_port != 0 &&
        listen_port != dds.link.tcp.listen) {
      errors.push_back(
          "dds.discovery.listen: over TCP the discovery server listens on the link's port (dds.tcp.listen" +
          (dds.link.tcp.listen == 0 ? std::string(" is missing") : " " + std::to_string(dds.link.tcp.listen)) +
          "), not on " + std::to_string(listen_port));
    }
  }
  if (const YAML::Node security = node["security"]) {
    util::check_keys(
        security, "dds.security",
        {"pki", "identity_ca", "certificate", "private_key", "permissions_ca", "governance", "permissions", "crl"},
        errors);
    federation::DdsSecurity& files = dds.link.security;
    const std::vector<std::pair<const char*, std::string*>> fields{{"pki", &dds.security_pki},
                                                                   {"identity_ca", &files.identity_ca},
                                                                   {"certificate", &files.certificate},
                                                                   {"private_key", &files.private_key},
                                                                   {"permissions_ca", &files.permissions_ca},
                                                                   {"governance", &files.governance},
                                                                   {"permissions", &files.permissions},
                                                                   {"crl", &files.crl}};
    for (const auto& [key, field] : fields) {
      if (security[key]) util::read_scalar(security[key], std::string("dds.security.") + key, *field, errors);
    }
    if (dds.security_pki.empty() && files.certificate.empty()) {
      errors.push_back("dds.security: give 'pki' (deploy/pki.sh's folder) or the files, 'certificate' among them");
    }
    if (!dds.link.discovery_listen.empty() || !dds.link.discovery_servers.empty()) {
      // DDS-Security rewrites each participant's GUID prefix from its certificate, so the
      // well-known prefix a discovery server's clients expect never matches (Fast DDS 2.9).
      errors.push_back(
          "dds.security: cannot be combined with dds.discovery (Fast DDS 2.9's discovery server "
          "does not work with DDS-Security); use dds.initial_peers between sites without multicast");
    }
  }
  if (const YAML::Node out = node["export"]) {
    util::check_keys(out, "dds.export", {"allow", "deny", "callers", "trust_declared_space"}, errors);
    read_filter(out, "dds.export", dds.export_allow, dds.export_deny, errors);
    if (out["callers"]) read_callers(out["callers"], dds.callers, errors);
    if (out["trust_declared_space"] &&
        util::read_scalar(out["trust_declared_space"], "dds.export.trust_declared_space",
                          dds.callers.trust_declared_space, errors) &&
        dds.callers.trust_declared_space) {
      if (!dds.callers.enabled) {
        errors.push_back("dds.export.trust_declared_space: has no effect without dds.export.callers");
      }
      if (node["security"]) {
        errors.push_back(
            "dds.export.trust_declared_space: a secured link proves each caller's space; a caller "
            "it cannot prove must not be judged by what it declares");
      }
    }
  }
  if (node["audit"]) read_audit(node["audit"], base, dds.audit, errors);
  if (const YAML::Node in = node["import"]) {
    util::check_keys(in, "dds.import", {"allow", "deny", "as_camus", "as_rtc", "deadline_ms"}, errors);
    read_filter(in, "dds.import", dds.import_allow, dds.import_deny, errors);
    if (in["as_camus"]) util::read_scalar(in["as_camus"], "dds.import.as_camus", dds.as_camus, errors);
    if (in["as_rtc"]) util::read_scalar(in["as_rtc"], "dds.import.as_rtc", dds.as_rtc, errors);
    if (in["deadline_ms"] && util::read_scalar(in["deadline_ms"], "dds.import.deadline_ms", dds.deadline_ms, errors) &&
        dds.deadline_ms == 0) {
      errors.push_back("dds.import.deadline_ms: must be > 0");
    }
  }
  if (node["state"]) read_state(node["state"], dds.link.domain, dds.state, errors);
}

}  // namespace

BridgeConfig load_bridge_config(const std::string& path, const std::string& host) {
  const YAML::Node root = util::load_yaml_file(path, "--config");
  if (!root.IsMap()) throw util::ConfigError("--config: '" + path + "' must be a YAML map");
  const std::string base = std::filesystem::absolute(path).parent_path().string();
  std::vector<std::string> errors;
  BridgeConfig config;
  config.name = "bridge@" + host;
  util::check_keys(root, "",
                   {"name", "instance", "activate", "workers", "queue", "idl", "include_dirs", "rt_to_camus",
                    "camus_to_rt", "data_to_camus", "events_to_rt", "dds"},
                   errors);
  read_string(root, "name", "", false, config.name, errors);
  read_string(root, "instance", "", false, config.instance, errors);
  if (root["activate"]) util::read_scalar(root["activate"], "activate", config.activate, errors);
  if (root["workers"] && util::read_scalar(root["workers"], "workers", config.workers, errors) &&
      (config.workers == 0 || config.workers > 256)) {
    errors.push_back("workers: " + std::to_string(config.workers) + " is outside 1..256");
  }
  if (root["queue"] && util::read_scalar(root["queue"], "queue", config.queue, errors) && config.queue > 1000000) {
    errors.push_back("queue: " + std::to_string(config.queue) + " is outside 0..1000000");
  }
  config.idl = read_paths(root["idl"], "idl", base, errors);
  config.include_dirs = read_paths(root["include_dirs"], "include_dirs", base, errors);

  if (const YAML::Node rt = root["rt_to_camus"]) {
    if (!rt.IsMap()) {
      errors.push_back("rt_to_camus: a map with 'providers' is expected");
    } else {
      util::check_keys(rt, "rt_to_camus", {"poll_ms", "providers"}, errors);
      read_ms(rt, "poll_ms", "rt_to_camus", config.rt_poll, errors);
      if (const YAML::Node list = list_of(rt, "providers", "rt_to_camus", errors)) {
        util::for_each_map(list, "rt_to_camus.providers", "a match", {"match", "interface", "name", "deadline_ms"},
                           errors, [&](const YAML::Node& node, const std::string& where) {
                             ProviderRule rule;
                             read_string(node, "match", where, true, rule.match, errors);
                             read_string(node, "interface", where, false, rule.interface, errors);
                             read_string(node, "name", where, false, rule.name, errors);
                             read_deadline(node, where, rule.deadline_ms, errors);
                             config.providers.push_back(std::move(rule));
                           });
      }
    }
  }
  if (const YAML::Node camus = root["camus_to_rt"]) {
    if (!camus.IsMap()) {
      errors.push_back("camus_to_rt: a map with 'services' is expected");
    } else {
      util::check_keys(camus, "camus_to_rt", {"poll_ms", "services"}, errors);
      read_ms(camus, "poll_ms", "camus_to_rt", config.camus_poll, errors);
      if (const YAML::Node list = list_of(camus, "services", "camus_to_rt", errors)) {
        util::for_each_map(list, "camus_to_rt.services", "a match", {"match", "instance", "deadline_ms"}, errors,
                           [&](const YAML::Node& node, const std::string& where) {
                             ServiceRule rule;
                             read_string(node, "match", where, true, rule.match, errors);
                             read_string(node, "instance", where, false, rule.instance, errors);
                             read_deadline(node, where, rule.deadline_ms, errors);
                             config.services.push_back(std::move(rule));
                           });
      }
    }
  }
  if (const YAML::Node list = list_of(root, "data_to_camus", "", errors)) {
    util::for_each_map(list, "data_to_camus", "match, port, type and topic",
                       {"match", "port", "type", "topic", "context"}, errors,
                       [&](const YAML::Node& node, const std::string& where) {
                         DataToCamus entry;
                         read_string(node, "match", where, true, entry.match, errors);
                         read_string(node, "port", where, true, entry.port, errors);
                         read_string(node, "type", where, true, entry.type, errors);
                         read_string(node, "topic", where, true, entry.topic, errors);
                         read_string(node, "context", where, false, entry.context, errors);
                         config.data_to_camus.push_back(std::move(entry));
                       });
  }
  if (const YAML::Node list = list_of(root, "events_to_rt", "", errors)) {
    util::for_each_map(list, "events_to_rt", "topic, type, match and port", {"topic", "type", "match", "port"}, errors,
                       [&](const YAML::Node& node, const std::string& where) {
                         EventsToRt entry;
                         read_string(node, "topic", where, true, entry.topic, errors);
                         read_string(node, "type", where, true, entry.type, errors);
                         read_string(node, "match", where, true, entry.match, errors);
                         read_string(node, "port", where, true, entry.port, errors);
                         config.events_to_rt.push_back(std::move(entry));
                       });
  }
  if (root["dds"]) read_dds(root["dds"], base, config.dds, errors);
  util::throw_if_errors(errors, "--config '" + path + "'");
  return config;
}

}  // namespace urs::bridge
