#include "bridge_metrics.hpp"

#include <algorithm>
#include <chrono>
#include <fastdds/dds/domain/DomainParticipant.hpp>

#include "urs/call/call.hpp"

namespace urs::bridge {

namespace {

using metrics::Kind;
using metrics::Sample;

constexpr std::size_t kMaxSpaceName = 64;

// The space of a participant of the link ("urs-bridge/<space>/<bridge>", dds_participant.cpp), if
// its name is one and the space a usable label value (printable ASCII, at most kMaxSpaceName).
std::optional<std::string> space_of_participant(const std::string& name) {
  static const std::string kPrefix = "urs-bridge/";
  if (name.rfind(kPrefix, 0) != 0) return std::nullopt;
  const auto end = name.find('/', kPrefix.size());
  if (end == std::string::npos || end == kPrefix.size()) return std::nullopt;
  std::string space = name.substr(kPrefix.size(), end - kPrefix.size());
  if (space.size() > kMaxSpaceName) return std::nullopt;
  if (std::any_of(space.begin(), space.end(), [](unsigned char c) { return c < 0x20 || c > 0x7e; })) {
    return std::nullopt;
  }
  return space;
}

std::string direction_label(const core::DirectionConfig& direction) { return direction.from + "->" + direction.to; }

}  // namespace

BridgeMetrics::BridgeMetrics(metrics::Metrics& metrics)
    : metrics_(metrics),
      calls_(prometheus::BuildCounter()
                 .Name("urslink_bridge_calls_total")
                 .Help("Calls the bridge's stand-ins took, by direction (from->to: services of side from standing "
                       "on side to), service, operation and final status.")
                 .Register(metrics.registry())),
      durations_(prometheus::BuildHistogram()
                     .Name("urslink_bridge_call_duration_seconds")
                     .Help("From a stand-in handing a call on to its outcome, by direction, service and operation.")
                     .Register(metrics.registry())) {}

call::CallRecorder* BridgeMetrics::direction(const core::DirectionConfig& direction) {
  const std::string label = direction_label(direction);
  auto& slot = directions_[label];
  if (!slot) {
    slot = std::make_unique<metrics::CallMetrics>(calls_, durations_, prometheus::Labels{{"direction", label}},
                                                  metrics_.max_call_series());
  }
  return slot.get();
}

std::map<std::string, BridgeMetrics::Space> BridgeMetrics::spaces(const federation::DdsLink& link) {
  const std::string& here = link.options().space;
  std::map<std::string, Space> now;
  for (const std::string& name : link.participant()->get_participant_names()) {
    const auto space = space_of_participant(name);
    if (space && *space != here) ++now[*space].participants;
  }
  for (const auto& entry : link.catalog()) ++now[entry.space].entries;
  for (auto& [name, calls] : link.space_calls()) {
    if (name != here) now[name].calls = std::move(calls);
  }
  for (const auto& [name, served] : link.space_served()) {
    // Only spaces seen otherwise: a caller's declared space (plain link) makes no series of its own.
    const auto known = now.find(name);
    if (known != now.end()) known->second.served = served;
  }
  std::map<std::string, Space> out;
  std::lock_guard lock(spaces_mutex_);
  for (const auto& [name, space] : now) {
    if (seen_.size() < kMaxSpaces || seen_.count(name)) seen_.insert(name);
  }
  for (const std::string& name : seen_) {
    const auto found = now.find(name);
    Space space = found == now.end() ? Space{} : found->second;
    // Lost: every bridge of it the link saw lost its liveliness or left, or nothing of it is left.
    space.up = (space.participants > 0 || space.entries > 0) && !link.lost_since(name);
    const auto reached = link.reached_since(name);
    if (space.up && reached) space.reached_since = std::chrono::duration<double>(reached->time_since_epoch()).count();
    out[name] = space;
  }
  return out;
}

void BridgeMetrics::watch(const core::Bridge& bridge) {
  const core::Bridge* watched = &bridge;
  metrics_.health().add("active", [watched] {
    return watched->status().active ? std::string() : "inactive (the bridge RTC is not activated)";
  });
  for (const std::string& name : bridge.sides()) {
    metrics_.health().add("side " + name, [watched, name] {
      const core::BridgeStatus status = watched->status();
      if (std::find(status.open.begin(), status.open.end(), name) == status.open.end()) {
        const auto failing = status.failing.find(name);
        return failing == status.failing.end() ? std::string("not open") : "not open: " + failing->second;
      }
      const core::Side* side = watched->side(name);
      return side == nullptr ? std::string() : side->not_ready();
    });
  }
  metrics_.add_scraped(
      "urslink_bridge_side_open", "Whether each side of the bridge is open (1) or not (0).", Kind::kGauge, [watched] {
        const core::BridgeStatus status = watched->status();
        std::vector<Sample> samples;
        for (const std::string& name : watched->sides()) {
          const bool open = std::find(status.open.begin(), status.open.end(), name) != status.open.end();
          samples.push_back({{{"side", name}}, open ? 1.0 : 0.0});
        }
        return samples;
      });
  metrics_.add_scraped("urslink_bridge_stand_ins", "Stand-ins the bridge offers now, by direction (from->to).",
                       Kind::kGauge, [watched] {
                         std::vector<Sample> samples;
                         for (const auto& direction : watched->status().directions) {
                           std::string label = direction.name;
                           label.erase(std::remove(label.begin(), label.end(), ' '), label.end());
                           samples.push_back({{{"direction", label}}, static_cast<double>(direction.routes.size())});
                         }
                         return samples;
                       });
  const auto* dds = dynamic_cast<const DdsSide*>(bridge.side("dds"));
  if (dds == nullptr) return;
  // The link's families: each reads the link anew at each scrape (spaces(): the catalog, the
  // participants and the calls' counts), ten reads per scrape.
  // `samples_of(name, space, samples)` adds a family's samples of each space; read(field) one each.
  auto each_space = [this, dds](auto samples_of) {
    std::vector<Sample> samples;
    const std::shared_ptr<federation::DdsLink> link = dds->link();
    if (!link) return samples;
    for (const auto& [name, space] : spaces(*link)) samples_of(name, space, samples);
    return samples;
  };
  auto read = [each_space](auto field) {
    return each_space([field](const std::string& name, const Space& space, std::vector<Sample>& samples) {
      samples.push_back({{{"space", name}}, field(space)});
    });
  };
  metrics_.add_scraped("urslink_bridge_link_up",
                       "Whether each other space is reachable over the link (1) or lost (0): seen on the link, and "
                       "not every bridge of it lost (its liveliness) or gone.",
                       Kind::kGauge, [read] { return read([](const Space& s) { return s.up ? 1.0 : 0.0; }); });
  metrics_.add_scraped("urslink_bridge_link_reached_since_timestamp_seconds",
                       "Since when each other space has been reachable (Unix time; 0 while it is not): an entry of "
                       "its catalog read from a bridge alive, and not every bridge of it lost since.",
                       Kind::kGauge, [read] { return read([](const Space& s) { return s.reached_since; }); });
  metrics_.add_scraped("urslink_bridge_link_participants",
                       "Participants of each other space discovered on the link (its bridges and gateways).",
                       Kind::kGauge,
                       [read] { return read([](const Space& s) { return static_cast<double>(s.participants); }); });
  metrics_.add_scraped("urslink_bridge_link_catalog_entries",
                       "Services of each other space in the catalog this bridge reads (imported).", Kind::kGauge,
                       [read] { return read([](const Space& s) { return static_cast<double>(s.entries); }); });
  metrics_.add_scraped("urslink_bridge_link_round_trips_total",
                       "Replies read to this bridge's calls to each other space (each one round trip of the link).",
                       Kind::kCounter,
                       [read] { return read([](const Space& s) { return static_cast<double>(s.calls.replies); }); });
  metrics_.add_scraped("urslink_bridge_link_round_trip_seconds_total",
                       "Round trips of the replies read from each other space, summed: a request written to its "
                       "reply read, the serving there included (divide by urslink_bridge_link_round_trips_total).",
                       Kind::kCounter,
                       [read] { return read([](const Space& s) { return s.calls.round_trip_seconds; }); });
  metrics_.add_scraped("urslink_bridge_link_last_round_trip_seconds",
                       "The latest round trip of a call to each other space (0 before the first reply).", Kind::kGauge,
                       [read] { return read([](const Space& s) { return s.calls.last_round_trip_seconds; }); });
  metrics_.add_scraped("urslink_bridge_link_last_failure_timestamp_seconds",
                       "When the link last failed a call to each other space (Unix time; 0 if never): no reply "
                       "within its deadline, the space's bridges lost or gone, the request not written.",
                       Kind::kGauge, [read] {
                         return read([](const Space& s) {
                           if (s.calls.failures.empty()) return 0.0;
                           return std::chrono::duration<double>(s.calls.last_failure_at.time_since_epoch()).count();
                         });
                       });
  metrics_.add_scraped("urslink_bridge_link_call_failures_total",
                       "Calls to each other space the link failed, by the status it gave them (an error the called "
                       "space answered is not one).",
                       Kind::kCounter, [each_space] {
                         return each_space([](const std::string& name, const Space& space, std::vector<Sample>& out) {
                           for (const auto& [status, count] : space.calls.failures) {
                             out.push_back({{{"space", name}, {"status", std::string(call::status_name(status))}},
                                            static_cast<double>(count)});
                           }
                         });
                       });
  metrics_.add_scraped(
      "urslink_bridge_link_payload_bytes_total",
      "Payload bytes of the calls between this bridge and each other space, by direction: sent (this bridge's "
      "requests, and its replies to that space's calls) and received (the replies read, and that space's requests).",
      Kind::kCounter, [each_space] {
        return each_space([](const std::string& name, const Space& space, std::vector<Sample>& out) {
          out.push_back({{{"space", name}, {"direction", "sent"}},
                         static_cast<double>(space.calls.request_bytes + space.served.reply_bytes)});
          out.push_back({{{"space", name}, {"direction", "received"}},
                         static_cast<double>(space.calls.reply_bytes + space.served.request_bytes)});
        });
      });
  metrics_.add_scraped("urslink_bridge_link_samples_lost_total",
                       "Samples the link's readers lost (DDS SAMPLE_LOST), by topic: DDS does not say whose.",
                       Kind::kCounter, [dds] {
                         std::vector<Sample> samples;
                         const std::shared_ptr<federation::DdsLink> link = dds->link();
                         if (!link) return samples;
                         for (const auto& [topic, count] : link->samples_lost()) {
                           samples.push_back({{{"topic", topic}}, static_cast<double>(count)});
                         }
                         return samples;
                       });
}

}  // namespace urs::bridge
