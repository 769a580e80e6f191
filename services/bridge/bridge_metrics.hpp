#pragma once
// What urs-bridge reports (docs/operations.md, "Monitoring"): the calls its stand-ins take, by
// direction (recorded by the core, once per call: urs/bridge/core/call_meter.hpp), the calls other
// spaces make to this one over DDS, and what it sees of the link to the other spaces, per remote
// space: whether the space is reachable, its participants on the link, the catalog entries
// imported from it, the round trips of the calls to it and the failures the link gave them; and
// the samples the link's readers lost, by topic. Its readiness: every side open (the DDS side: joined to its link) and
// working (the CAMUS side: its session connected).
//
// Threading: direction() while the bridge is built; the rest is read by the metrics endpoint's
// thread when Prometheus scrapes.

#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/histogram.h>

#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "urs/bridge/core/bridge.hpp"
#include "urs/bridge/dds/dds_side.hpp"
#include "urs/metrics/metrics.hpp"

namespace urs::bridge {

class BridgeMetrics {
 public:
  // Spaces beyond this many get no series of their own (their names come from the link).
  static constexpr std::size_t kMaxSpaces = 64;

  // Adds the bridge's families to `metrics`, which outlives this object.
  explicit BridgeMetrics(metrics::Metrics& metrics);
  BridgeMetrics(const BridgeMetrics&) = delete;
  BridgeMetrics& operator=(const BridgeMetrics&) = delete;

  // core::Bridge::CallRecorders: the recorder of one direction's calls.
  call::CallRecorder* direction(const core::DirectionConfig& direction);
  // Adds the readiness checks and the link's families, read from `bridge` (and its DDS side, if
  // it has one) at each scrape; `bridge` outlives this object's use by the endpoint.
  void watch(const core::Bridge& bridge);

  // One remote space as the link shows it now.
  struct Space {
    bool up = false;                 // reachable: seen on the link, and not lost (DdsLink::lost_since)
    std::size_t participants = 0;    // its participants discovered on the link
    std::size_t entries = 0;         // its catalog entries this bridge reads (live ones)
    federation::SpaceCalls calls;    // what this bridge's calls to it met (DdsLink::space_calls)
    federation::SpaceServed served;  // what this bridge served to its calls (DdsLink::space_served)
    double reached_since = 0;        // Unix seconds since when it is reached (DdsLink::reached_since); 0: not
  };
  // The spaces of the link but this one (at most kMaxSpaces), by name; a space once seen stays
  // (down) when it is gone.
  std::map<std::string, Space> spaces(const federation::DdsLink& link);

 private:
  metrics::Metrics& metrics_;
  prometheus::Family<prometheus::Counter>& calls_;
  prometheus::Family<prometheus::Histogram>& durations_;
  std::map<std::string, std::unique_ptr<metrics::CallMetrics>> directions_;  // by "from -> to"

  std::mutex spaces_mutex_;
  std::set<std::string> seen_;  // the spaces seen (at most kMaxSpaces)
};

}  // namespace urs::bridge
