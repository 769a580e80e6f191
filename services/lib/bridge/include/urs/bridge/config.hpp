#pragma once
// urs-bridge configuration (YAML), validated once into an immutable struct; docs/bridge.md.
//
//   name: bridge-lab                # Planet peer name (default bridge@<host>)
//   instance: Bridge0               # the bridge's RTC instance name (default Bridge<N>)
//   activate: true                  # activate the bridge RTC at start (default true)
//   workers: 16                     # threads running bridged calls towards RT providers
//   queue: 1024                     # calls waiting for a worker beyond which one is refused (0: none)
//   idl: [path/Thermostat.idl]      # interfaces the bridge was not built with, loaded at start
//   include_dirs: [path]            # where those files' #includes are found
//   rt_to_camus:                    # RT provider ports offered as CAMUS services
//     poll_ms: 200
//     providers:
//       - match: "*/Robot*.rtc"     # glob on naming paths ('*' crosses '/')
//         interface: URC::Navigation  # glob on the provided interface's type_name (default "*")
//         name: "{instance}.{port}" # the CAMUS service name; {instance} {port} {interface} {host}
//                                   # ({host}: the naming context <host>.host_cxt the RTC is bound in)
//         deadline_ms: 10000        # bound on each call (advertised to CAMUS callers too)
//   camus_to_rt:                    # CAMUS services offered as RT-Components
//     poll_ms: 10000                # fallback: the registry is read on its registry/<name> events
//     services:
//       - match: "tts*"             # glob on CAMUS service names
//         instance: "{service}"     # RTC instance name; characters other than [A-Za-z0-9_-] become '_'
//         deadline_ms: 10000
//   data_to_camus:                  # RT OutPorts feeding CAMUS events (and context)
//     - match: "*/Localizer*.rtc"
//       port: pose                  # the OutPort's name
//       type: URC.PoseWithCovariance  # the values' type (Protobuf full name of an IDL struct)
//       topic: robot1/pose          # Planet topic of the events
//       context: robot1.pose        # optional: context entry set to each value (as JSON)
//   dds:                            # link to other spaces over DDS (docs/federation.md)
//     domain: 0
//     lease_ms: 3000                # a silent bridge's services and state leave the others after this
//     hold_lost_ms: 30000           # ... but its services stay offered, "unreachable" (calls refused with
//                                   #   UNAVAILABLE naming the space), this long after (0: none)
//     participant_lease_ms: 20000   # a silent participant is dropped after this (>= lease_ms; no
//                                   #   shorter than any peer's own lease: docs/federation.md)
//     udp_only: false               # true between containers (no shared memory)
//     socket_buffer_bytes: 4194304
//     initial_peers: [bridge-kr]    # HOST or HOST:PORT, for networks without multicast
//     interfaces: ["127.0.0.1"]     # the link's UDP/TCP uses only these addresses of this host's
//                                   #   interfaces (default: all; shared memory unaffected)
//     transport: udp                # or tcp: one TCP connection between sites (docs/sites.md)
//     tcp:                          # with transport: tcp
//       listen: 7400                #   this site listens on this port (forwarded by its router)
//       public: "198.51.100.2:7400" #   where the others reach it: IPv4[:PORT] (PORT: listen's)
//       connect: ["198.51.100.2:7400"]  # or/and: the listening sites' public HOST:PORT
//       rejoin_after_ms: 20000      #   a site connecting out that met no one this long joins again (0: never)
//     security:                     # DDS-Security between spaces (docs/federation.md, "A secured link")
//       pki: /run/secrets/federation  # deploy/pki.sh's folder: ca.pem, governance.p7s, crl.pem, <space>/...
//       # or, each overriding the folder's: identity_ca, certificate, private_key, permissions_ca,
//       # governance, permissions, crl
//     discovery:                    # or a Fast DDS discovery server (docs/federation.md):
//       listen: "0.0.0.0:11811"     #   this bridge is the server (with id `id`, default 0)
//       servers: ["site-a:11811"]   #   or a client of these servers (the N-th has id N)
//     export:
//       allow: ["*"]                # globs on this space's service names
//       deny: []
//       callers:                    # who may call which exported service (docs/federation.md,
//         "rt.Diagnostic*": [kr, "jp/dds:jp"]  #   "Who may call what"); the first glob matching
//         "*": [kr]                 #   a service decides; SPACE or SPACE/NAME, globs. Absent:
//                                   #   any space that reaches the service
//       trust_declared_space: false # plain link only: judge callers by the space they declare
//     audit: {file: /var/log/urs/calls.jsonl, max_bytes: 10485760, files: 5}
//                                   # a JSON line per call served to another space, rotated
//     import: {allow: ["*"], deny: [],             # globs on "<space>/<service>"
//              as_camus: "{space}/{service}",      # CAMUS name ("" = not on CAMUS)
//              as_rtc: "{space}_{service}",        # RTC instance ("" = not in naming)
//              deadline_ms: 10000}
//     state:                        # shared state besides the catalog
//       components: true            # RTC lifecycle states and CAMUS agents of this space
//       period_ms: 1000             # how often RTC states are read
//       poses: {domain: 1, source: localizer, robots: [robot1], period_ms: 100}
//                                   # relay the robots' poses from the devices' own domain
//       events: ["robot1.navigation/#"]   # Planet patterns of the CAMUS events shared
//       context: {allow: ["robot1.*"], deny: []}  # globs on the CAMUS context keys shared
//       import: true                # the others' state into this space's CAMUS context/events:
//                                   # <space>/component/<name>, <space>/pose/<robot>,
//                                   # <space>/<key>, events on <space>/<topic>
//   events_to_rt:                   # CAMUS events feeding RT InPorts
//     - topic: "robot1.navigation/arrived"  # Planet subscription pattern
//       type: URC.Pose2D            # the events' type; others on the topic are skipped
//       match: "*/Sink*.rtc"
//       port: arrived               # the InPort's name

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "urs/bridge/core/rules.hpp"              // glob_match, allowed, expand
#include "urs/bridge/dds/call_audit.hpp"          // AuditConfig
#include "urs/bridge/dds/call_authorization.hpp"  // CallerPolicy
#include "urs/federation/dds_link.hpp"            // DdsOptions
#include "urs/federation/state_link.hpp"          // PoseRelay

namespace urs::bridge {

struct ProviderRule {
  std::string match = "*";
  std::string interface = "*";
  std::string name = "{instance}.{port}";
  uint32_t deadline_ms = 10000;
};

struct ServiceRule {
  std::string match;
  std::string instance = "{service}";
  uint32_t deadline_ms = 10000;
};

struct DataToCamus {
  std::string match;
  std::string port;
  std::string type;
  std::string topic;
  std::string context;  // "" = no context entry
};

struct EventsToRt {
  std::string topic;
  std::string type;
  std::string match;
  std::string port;
};

// What a space shares over DDS besides its catalog (federation::StateLink, docs/federation.md).
struct StateConfig {
  bool components = true;                  // RTC lifecycle states and CAMUS agents
  std::chrono::milliseconds period{1000};  // how often RTC states are read
  std::optional<federation::PoseRelay> poses;
  std::vector<std::string> events;         // Planet patterns of the CAMUS events shared
  std::vector<std::string> context_allow;  // globs on the CAMUS context keys shared (none by default)
  std::vector<std::string> context_deny;
  bool import = true;  // the others' state into this space's CAMUS context and events
};

// The link's settings as the bridge's defaults have them: a participant lease of 20 s, or
// lease_ms if longer (load_bridge_config).
federation::DdsOptions bridge_link_defaults();

struct DdsConfig {
  bool enabled = false;
  // domain, lease, participant_lease, udp_only, socket_buffer_bytes, initial_peers, discovery_*;
  // `space` and `bridge` are left empty here (the bridge sets them from BridgeConfig).
  federation::DdsOptions link = bridge_link_defaults();
  // dds.security.pki: a folder laid out by deploy/pki.sh whose files of this space (as the bridge
  // learns its space) fill link.security where dds.security names no file of its own.
  std::string security_pki;
  std::vector<std::string> export_allow{"*"};
  std::vector<std::string> export_deny;
  CallerPolicy callers;  // dds.export.callers, dds.export.trust_declared_space
  AuditConfig audit;     // dds.audit (file "" = none)
  std::vector<std::string> import_allow{"*"};
  std::vector<std::string> import_deny;
  std::string as_camus = "{space}/{service}";
  std::string as_rtc = "{space}_{service}";
  uint32_t deadline_ms = 10000;
  std::chrono::milliseconds hold_lost{30000};     // dds.hold_lost_ms (DdsSideConfig::hold_lost)
  std::chrono::milliseconds rejoin_unmet{20000};  // dds.tcp.rejoin_after_ms (DdsSideConfig::rejoin_unmet)
  StateConfig state;
};

struct BridgeConfig {
  std::string space;  // the space the bridge belongs to (set from --space)
  // Where the connections of the bridge's RTCs are kept across restarts (set from --data-dir;
  // "" keeps them nowhere). See ConnectionStore.
  std::string data_dir;
  std::string name;
  std::string instance;
  bool activate = true;
  unsigned workers = 16;
  std::size_t queue = 1024;  // of each side's AgentHost (agent::HostOptions::max_queued)
  std::vector<std::string> idl;
  std::vector<std::string> include_dirs;
  std::chrono::milliseconds rt_poll{200};
  std::chrono::milliseconds camus_poll{10000};  // a fallback: registry/<name> events wake the CAMUS directions
  std::vector<ProviderRule> providers;
  std::vector<ServiceRule> services;
  std::vector<DataToCamus> data_to_camus;
  std::vector<EventsToRt> events_to_rt;
  DdsConfig dds;
};

// Parses and validates `path`; relative idl/include_dirs paths are taken from the file's folder.
// Throws urs::util::ConfigError listing every problem with its key path.
BridgeConfig load_bridge_config(const std::string& path, const std::string& host);

}  // namespace urs::bridge
