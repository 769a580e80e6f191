#pragma once
// DdsSide: the bridge's side towards the other spaces (docs/federation.md), on the DDS link
// (urs::federation). While open it is one participant of the link:
//
//   ServiceSource    the other spaces' catalog as offers (key and name "<space>/<service>", fields
//                    {space} {service}, revision the interface and its description); the calls to
//                    one go over the link (a ForwardingAgent over DdsCallSink), one agent per
//                    service shared by its stand-ins
//   ServiceOffering  this space's catalog: a stand-in is an announced entry, and the agent serving
//                    it (the source side's) hosted on this side's AgentHost under the entry's name;
//                    each call from another space is judged by dds.export.callers
//                    (call_authorization.hpp), refused ones answered PERMISSION_DENIED with the
//                    reason, recorded in the audit log when dds.audit names a file
//                    (call_audit.hpp), and dispatched to that host
//   StateSink        this space's state, written on the link (StateLink): components, context
//                    entries, events; robot poses are relayed by StateLink itself
//   StateSource      the other spaces' state: components as entries "component/<name>" {"kind",
//                    "state", "type_name", "host"}, poses as "pose/<robot>" {"x", "y", "theta",
//                    "stamp_unix_ns"} (a string: 64 bits, as Protobuf's JSON writes them), context
//                    entries and events as they came
//
// poll() reads the catalog again once a lease (offers_changed), and once a lease says the others
// may have forgotten what this space announced (stand_ins_lost: it is announced again); on a site
// connecting out over TCP, it asks to be opened again while its link has matched no one
// (DdsSideConfig::rejoin_unmet).
//
// Threads: the control methods on the bridge's thread; calls from other spaces arrive on DDS
// listener threads (never blocked); the other spaces' state is handed to the sink on StateLink's
// reader thread and Fast DDS's listener threads; the StateSink methods from any thread.

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "urs/bridge/core/side.hpp"
#include "urs/bridge/dds/call_audit.hpp"
#include "urs/bridge/dds/call_authorization.hpp"
#include "urs/call/recorder.hpp"
#include "urs/federation/dds_link.hpp"
#include "urs/federation/state_link.hpp"
#include "urs/schema/schema.hpp"

namespace urs::bridge {

struct DdsSideConfig {
  std::string space;   // this space
  std::string bridge;  // this bridge's name
  // domain, leases, transports, peers, discovery, security (link.space and link.bridge are set from
  // the two above).
  federation::DdsOptions link;
  // A folder laid out by deploy/pki.sh whose files of this space fill link.security where it names
  // no file of its own ("": none).
  std::string security_pki;
  CallerPolicy callers;  // who may call which exported service
  AuditConfig audit;     // file "": no audit log
  std::optional<federation::PoseRelay> poses;
  // How long another space's services stay offered here once its bridges are all lost (killed,
  // paused, cut off): their calls answer UNAVAILABLE naming the space, `urs ls` shows them
  // "unreachable", and a space back within it finds its stand-ins where they were. 0: they leave
  // with their space at once.
  std::chrono::milliseconds hold_lost{30000};
  // A site connecting out over TCP (link.tcp.connect, or discovery servers over TCP) whose link has
  // matched no other bridge or gateway (DdsLink::catalog_writers_matched) this long after joining
  // leaves and joins again (the side is opened again: SideEvents::reopen): Fast DDS 2.9.1's TCP
  // transport can leave a first connection established with nothing flowing, or with discovery
  // only, for good (docs/sites.md, "Limits"). 0: never.
  std::chrono::milliseconds rejoin_unmet{20000};
  unsigned workers = 16;     // threads running the calls from other spaces that block (RT providers)
  std::size_t queue = 1024;  // calls waiting for a worker beyond which a call is refused
};

class DdsSide final : public core::Side,
                      public core::ServiceSource,
                      public core::ServiceOffering,
                      public core::StateSource,
                      public core::StateSink {
 public:
  explicit DdsSide(DdsSideConfig config);
  ~DdsSide() override;  // close()

  // core::Side
  void start(core::SideEvents& events) override;
  // Joins the link (and opens the audit log). Throws util::Unavailable if DDS refuses now (a peer's
  // or discovery server's name that does not resolve yet), util::ConfigError if the audit log
  // cannot be opened.
  void open() override;
  // Leaves the link: the others drop this space's services and state at once.
  void close() override;
  Clock::time_point poll(Clock::time_point now) override;
  core::ServiceSource* services() override { return this; }
  core::ServiceOffering* offering() override { return this; }
  core::StateSource* state_source() override { return this; }
  core::StateSink* state_sink() override { return this; }

  // The link while the side is on it (else null), for what the bridge's metrics read of it. From
  // any thread.
  std::shared_ptr<federation::DdsLink> link() const;
  // Where the calls of other spaces to this one are recorded as they are answered (refusals
  // included; call::CallRecorder::record: names of this space's catalog only); null: nowhere. Set
  // before the bridge starts; `calls` outlives the side.
  void record_served(call::CallRecorder* calls) { served_calls_ = calls; }

  // core::ServiceSource
  std::string kind() const override { return "RemoteService"; }
  std::optional<std::vector<core::Offer>> offers() override;
  std::shared_ptr<agent::ServiceAgent> serve(const core::Route& route) override;

  // core::ServiceOffering
  core::OfferOutcome offer(const core::Route& route, core::ServiceSource& from) override;
  void withdraw(const core::Route& route) override;
  void update(const core::Route& route) override;

  // core::StateSource
  void share_state(core::StateSink* sink) override;

  // core::StateSink
  void entry(const core::StateEntry& entry, bool alive) override;
  void event(const core::StateEvent& event) override;
  void components(const std::string& kind, const std::vector<core::ComponentState>& now) override;

 private:
  struct Session;  // one membership of the link

  std::shared_ptr<Session> session() const;
  void serve_call(Session& session, call::Request request, call::Responder responder);
  void announce(const core::Route& route, const agent::ServiceAgent& agent);
  // The other spaces' state, from StateLink's threads, into the sink.
  federation::StateHandlers importing();

  const DdsSideConfig config_;
  core::SideEvents* events_ = nullptr;
  call::CallRecorder* served_calls_ = nullptr;

  std::shared_ptr<Session> session_;  // the bridge's thread swaps it; DDS threads read it under session_mutex_
  mutable std::mutex session_mutex_;

  // The bridge's thread only:
  bool failed_to_join_ = false;  // the last open() could not join the link
  Clock::time_point catalog_read_at_{};
  Clock::time_point announced_at_{};
  Clock::time_point joined_at_{};                            // when open() joined the link
  bool rejoin_asked_ = false;                                // reopen() asked since
  std::map<std::string, federation::ServiceEntry> catalog_;  // the others' entries last read, by "<space>/<service>"
  // Of catalog_, those no longer in the link's catalog but held: while their space is lost (up to
  // hold_lost), or just back and yet to announce them again.
  struct Held {
    Clock::time_point until;  // when the hold ends
    bool lost = false;        // their space is lost (else back): shown unreachable
    Clock::time_point since;  // when it was lost
    int64_t lost_at = 0;      // the same, Unix seconds (core::kUnreachableSinceProperty)
  };
  std::map<std::string, Held> held_;
  struct Forwarding {
    std::string revision;
    std::shared_ptr<agent::ServiceAgent> agent;
  };
  std::map<std::string, Forwarding> forwarding_;  // by "<space>/<service>": one agent for its stand-ins
  // The other spaces' interfaces, kept as long as the side: the agents made from them may outlive
  // a session (a call in flight).
  std::map<std::string, std::unique_ptr<schema::SchemaPool>> space_pools_;
  std::vector<std::unique_ptr<schema::SchemaPool>> extra_pools_;  // descriptions that clash within a space

  std::mutex sink_mutex_;  // held while the other spaces' state is handed over
  core::StateSink* sink_ = nullptr;

  std::mutex shared_mutex_;
  std::map<std::string, std::set<std::string>> shared_components_;  // this space's, by kind
};

}  // namespace urs::bridge
