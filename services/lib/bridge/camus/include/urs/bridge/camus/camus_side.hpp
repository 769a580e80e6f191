#pragma once
// CamusSide: the bridge's CAMUS side (docs/bridge.md). While open it is one Planet session with the
// space's CAMUS server (a SAM-role client) and an AgentHost of the agents standing for other sides'
// services:
//
//   ServiceSource    the registry's available services but this bridge's own, as offers (key and
//                    name the service name, fields {service}, origin its urslink.origin, built_in
//                    the server's camus.*, source "camus:<service>"); read again at once when the
//                    server publishes registry/<name> (a change), else every period (a slow
//                    fallback); the calls to one go to the server (a ForwardingAgent over Planet),
//                    its interface described by the registry
//   ServiceOffering  a stand-in is a service hosted here and registered with the properties
//                    urslink.origin=<offer source>, urslink.bridge=<bridge> and the offer's; a
//                    change of the offer's properties registers it again (the registry's entry is
//                    replaced); the client registers again by itself after a reconnect
//   StateSource      this space's CAMUS agents (as components of kind "agent"), the events of the
//                    configured patterns and the context entries the filters allow, as they change
//   StateSink        other spaces' state into this space: an entry <space>/<key> set in the context
//                    with source "dds:<space>" (only the newest of a key waits to be written), an
//                    event published on <space>/<topic>; nothing imported is shared again
//   StreamSource     the events of subscribe[N] (of its type), as stream entry N
//   StreamSink       stream entry N published on publish[N].topic (and set as context publish[N].context)
//
// Threads: the control methods on the bridge's thread (offers() and serve() block on the
// registry, at most 2 s); the StreamSink and StateSink methods from any thread, never blocking:
// imports are written by one importer thread, exports handed over by one exporter thread, each in
// arrival order (never on the Planet client's I/O thread).

#include <google/protobuf/dynamic_message.h>

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "urs/bridge/core/side.hpp"
#include "urs/planet/client.hpp"
#include "urs/schema/interface_catalog.hpp"
#include "urs/schema/schema.hpp"

namespace urs::bridge {

struct CamusSideConfig {
  std::string bridge;        // the bridge's name: its Planet peer name; services it owns are not offers
  unsigned workers = 16;     // threads running the calls of stand-ins that block
  std::size_t queue = 1024;  // calls waiting for a worker beyond which a call is refused
  struct Publish {
    std::string topic;
    std::string context;  // "": no context entry
  };
  std::vector<Publish> publish;  // stream entry N -> events (StreamSink)
  struct Subscribe {
    std::string topic;  // a Planet pattern
    std::string type;   // the events' type (full name); others on the topic are skipped
  };
  std::vector<Subscribe> subscribe;  // events -> stream entry N (StreamSource)
  // What it shares of this space (StateSource).
  bool share_agents = false;
  std::vector<std::string> share_events;         // Planet patterns
  std::vector<std::string> share_context_allow;  // globs on context keys (none: no context shared)
  std::vector<std::string> share_context_deny;
  // Takes other spaces' state (StateSink): what a previous run imported is removed at open.
  bool import_state = false;
};

class CamusSide final : public core::Side,
                        public core::ServiceSource,
                        public core::ServiceOffering,
                        public core::StateSource,
                        public core::StateSink,
                        public core::StreamSource,
                        public core::StreamSink {
 public:
  // `catalog` (the streams' types) outlives the side; `client`'s peer name and role are set here.
  CamusSide(CamusSideConfig config, const schema::InterfaceCatalog& catalog, planet::ClientOptions client);
  ~CamusSide() override;  // close()

  // core::Side
  void start(core::SideEvents& events) override;
  // Starts the session (connects in the background: the client queues until it is connected).
  void open() override;
  void close() override;
  // "not connected to the CAMUS server" until its session is (again).
  std::string not_ready() const override;
  core::ServiceSource* services() override { return this; }
  core::ServiceOffering* offering() override { return this; }
  core::StateSource* state_source() override { return this; }
  core::StateSink* state_sink() override { return this; }
  core::StreamSource* stream_source() override { return this; }
  core::StreamSink* stream_sink() override { return this; }

  // core::ServiceSource
  std::string kind() const override { return "CamusService"; }
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

  // core::StreamSource
  void stream_to(core::StreamSink* sink) override;
  // core::StreamSink
  void write(std::size_t entry, const google::protobuf::Message& value) override;

 private:
  struct Session;

  std::shared_ptr<Session> session() const;
  std::map<std::string, std::string> properties_of(const core::Route& route) const;
  void register_service(Session& session, const agent::HostedService& hosted, const std::string& what);
  void export_event(Session& session, const planet::Event& event);
  void export_context(Session& session, const planet::Event& event);
  void import_next(Session& session, const std::string& key);
  void clear_stale_imports(Session& session);

  const CamusSideConfig config_;
  const schema::InterfaceCatalog& catalog_;
  planet::ClientOptions client_options_;
  core::SideEvents* events_ = nullptr;

  mutable std::mutex session_mutex_;
  std::shared_ptr<Session> session_;

  // The bridge's thread only.
  schema::SchemaPool described_;  // interfaces of CAMUS services, from the registry; kept as long as the side
  bool warned_registry_ = false;

  std::mutex state_mutex_;  // held while state is handed to state_sink_
  core::StateSink* state_sink_ = nullptr;
  std::mutex stream_mutex_;  // held while a value is handed to stream_sink_
  core::StreamSink* stream_sink_ = nullptr;
};

}  // namespace urs::bridge
