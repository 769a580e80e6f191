#pragma once
// The connections the bridge's RT-Components hold (the bridge RTC and the RTCs standing for CAMUS
// and other spaces' services), kept in a file so that a restarted bridge can make them again.
//
// Why a file: a restarted bridge is a new process whose ports are new objects. An RT consumer
// that was connected to the old ones cannot say so any more: OpenRTM-aist's ports (and URSLink's)
// drop a connection whose peer no longer exists as soon as their profile is read, before anyone
// sees it. So the bridge writes down, as it runs, what each of its ports is connected to (the
// peers' IORs, the connector's id, name and properties) and, after a restart, first drops the
// old halves still held by the peers (notify_disconnect on each peer, by id: no profile read),
// then connects the peers again to its new ports under the same ids.
//
// File format (YAML, written by the bridge; docs/bridge.md "Restarts"):
//   connections:
//     - rtc: "camus:diag"          # "bridge" (the bridge RTC) or the origin of an RTC it made
//       port: diagnostic           # our port's short name
//       id: 5f0c...                # connector id
//       name: "MyConsumer0.myservice0_..."
//       made_by_bridge: false      # true: the bridge's discovery made it (its rules make it again)
//       ports: ["IOR:...", ""]     # every port of the connection in order; "" is ours
//       properties: {port.connection.strictness: best_effort, ...}  # string ones, no IOR
//
// Threading: not thread-safe; the bridge's own thread uses it.

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "RTC.hh"

namespace urs::bridge {

struct SavedConnection {
  std::string rtc;
  std::string port;
  std::string id;
  std::string name;
  bool made_by_bridge = false;
  std::vector<std::string> ports;  // IORs in profile order, "" for ours
  std::map<std::string, std::string> properties;

  bool operator==(const SavedConnection& other) const;
};

// What to keep of a connection our port `ours` holds: the peers by IOR and the string-valued
// properties that are not published IORs (the ports publish those again when reconnected).
// `peer_ior` turns a peer's reference into its IOR. False if the connection has no other port
// (nothing to make again).
bool describe_connection(const RTC::ConnectorProfile& profile, RTC::PortService_ptr ours, const std::string& rtc,
                         const std::string& port, bool made_by_bridge,
                         const std::function<std::string(CORBA::Object_ptr)>& peer_ior, SavedConnection& out);

class ConnectionStore {
 public:
  // `path` is the file; "" keeps nothing (load() is empty, save() does nothing).
  explicit ConnectionStore(std::string path);

  const std::string& path() const { return path_; }
  // The connections last saved. A missing file is none; an unreadable one is logged and taken
  // as none, as is each malformed entry (named in the log).
  std::vector<SavedConnection> load() const;
  // Writes `connections` (atomically) if they differ from what was last written or loaded.
  // Logs, never throws, when the file cannot be written.
  void save(const std::vector<SavedConnection>& connections);

 private:
  std::string path_;
  mutable std::string written_;  // the text last written or read
};

}  // namespace urs::bridge
