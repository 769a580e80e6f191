#pragma once
// DdsSource: every linked space seen on the DDS link (idl/dds/Federation.idl, SpaceState.idl;
// docs/federation.md), read only: the gateway joins the link's domain with a DdsLink and a
// StateLink of its own, under a name no bridge uses (so every space's entries, its own space's
// included, reach it), and writes nothing there: no catalog entry, no state, no call.
//   services    the catalog: what each space's bridge exports, with its origin and bridge; an
//               entry leaves when its bridge stops asserting its liveliness (the link's lease)
//   components  RT-Component states and CAMUS agents each bridge shares
//   poses, context, events   what the bridges share; event payloads decoded with the link's
//               interface descriptions
// What the gateway's own space's native sources show better (the CAMUS server, the naming
// service, the devices' domain) is left out here, as DdsSourceOptions says.
//
// Threads: one of its own for joining the link and the catalog (read when DDS says it changed); the state arrives on
// StateLink's threads and is reported from there.

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "urs/federation/dds_link.hpp"
#include "urs/federation/link_retry.hpp"
#include "urs/federation/state_link.hpp"
#include "urs/gateway/payloads.hpp"
#include "urs/gateway/poller.hpp"
#include "urs/gateway/space_view.hpp"

namespace urs::gateway {

struct DdsSourceOptions {
  std::string space;            // the gateway's own space
  federation::DdsOptions link;  // domain, lease, transports, peers; `space` and `bridge` are set here
  bool own_services = true;     // the own space's catalog entries and components too
  bool own_state = true;        // the own space's context entries and events too
  bool own_poses = true;        // the own space's poses too
};

class DdsSource : public SpaceSource {
 public:
  explicit DdsSource(DdsSourceOptions options);
  ~DdsSource() override;

  // Joins the domain, or, while DDS refuses (a peer's name that does not resolve yet), logs why and
  // tries again every 2 s; never throws for that.
  void start(ViewSink& sink) override;
  void stop() override;

  // The participant name the gateway reads the link under.
  static std::string reader_name(const std::string& space);

 private:
  void join();
  federation::StateHandlers state_handlers();
  void read_catalog();
  void component(const federation::ComponentState& state, bool alive);
  bool wanted(const std::string& space, bool own) const { return own || space != options_.space; }

  const DdsSourceOptions options_;
  ViewSink* sink_ = nullptr;
  PayloadDecoder decoder_;
  std::unique_ptr<federation::DdsLink> link_;
  std::unique_ptr<federation::StateLink> state_;

  std::mutex components_mutex_;
  std::map<std::pair<std::string, std::string>, Component> components_;
  federation::LinkRetry link_retry_;  // the poller's thread only (and start()'s, before it runs)
  Poller poller_;  // joins the link until it is joined, then reads the catalog when DDS says it changed; liveliness
                   // ends at a lease's pace
};

}  // namespace urs::gateway
