#pragma once
// Gateway: the whole picture of the linked spaces, put together from what the sources report
// (ViewSink), and offered on the hub's channels and services (docs/dashboard.md lists them):
//
//   /graph        urs.gateway.Graph       the spaces, their middlewares and bridges, the DDS link
//   /services     urs.gateway.Services    every service of every space, with origin and health
//   /components   urs.gateway.Components  RT-Components (ports, connections) and CAMUS agents
//   /poses        urs.gateway.Pose        every robot's poses (the last per robot is latched)
//   /trails       urs.gateway.Trail       each robot's recent path (for clients that join late)
//   /context      urs.gateway.ContextEntry  context entries of every space (latched per key)
//   /events       urs.gateway.Event       events of every space, payloads decoded (recent ones kept)
//   /calls        urs.gateway.Call        every call made through the gateway, with its reply
//   /<space>/<robot>/pose                 one robot's poses, for plots in Foxglove and Lichtblick
//
// and the sources' operations as Foxglove services, plus the connection graph.
// Threading: the ViewSink methods may be called from any thread (one mutex); they publish on the
// hub before returning and never block on the network.

#include <chrono>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "urs/gateway/hub.hpp"
#include "urs/gateway/space_view.hpp"

namespace urs::gateway {

struct GatewayOptions {
  std::string space;                     // the gateway's own space
  std::vector<std::string> middlewares;  // of its own space: "camus", "rtc"
  bool dds = false;                      // it reads the DDS link
  uint32_t dds_domain = 0;
  std::size_t trail_points = 600;  // per robot
  // A trail point only when the robot moved this far from the last one: more than a localizer's
  // noise (2 cm standard deviation by default), so a robot standing still keeps its path.
  double trail_spacing_m = 0.1;
  std::chrono::milliseconds trail_period{1000};  // /trails is published at most this often per robot
  std::size_t event_history = 200;               // events kept for clients that subscribe later
  std::size_t max_robots = 64;                   // robots with a channel of their own
  std::size_t call_history = 100;                // calls kept for clients that subscribe later
  std::size_t max_call_json = 64 * 1024;         // a longer request or reply is left out of /calls
};

class Gateway : public ViewSink {
 public:
  // Creates the fixed channels on `hub` (which outlives this).
  Gateway(GatewayOptions options, Hub& hub);
  ~Gateway() override;
  Gateway(const Gateway&) = delete;
  Gateway& operator=(const Gateway&) = delete;

  // ViewSink
  void services(const std::string& source, std::vector<Service> now) override;
  void components(const std::string& source, std::vector<Component> now) override;
  void operations(const std::string& source, std::vector<Operation> now) override;
  void pose(const Pose& pose) override;
  void context(const ContextEntry& entry) override;
  void event(const Event& event) override;

  // A call made through the gateway, answered: published on /calls (a recording's, when playing).
  void call(const Call& call);

  // The hub's channel id of a fixed topic ("/poses"), 0 if none; for tests and benchmarks.
  uint32_t channel(const std::string& topic) const;

 private:
  struct Robot {
    uint32_t channel = 0;  // its own channel, 0 if over max_robots
    std::deque<TrailPoint> trail;
    std::chrono::steady_clock::time_point trail_sent;
  };
  struct Offered {
    uint32_t id = 0;
    std::string type;
    std::string request_schema;
    std::string response_schema;
  };

  void serve(const std::string& name, const Caller& caller, std::string json, std::function<void(CallReply)> reply);
  void publish_snapshots();  // caller holds mutex_
  void publish_graph();      // caller holds mutex_
  void publish(uint32_t channel, const google::protobuf::Message& message, uint64_t stamp_ns,
               const std::string& key = {}, bool removed = false);
  uint32_t fixed(const std::string& topic, const google::protobuf::Descriptor& type, Latch latch,
                 std::size_t history = 0);

  const GatewayOptions options_;
  Hub& hub_;
  std::map<std::string, uint32_t> fixed_;  // topic -> channel id
  mutable std::mutex mutex_;
  std::map<std::string, std::vector<Service>> services_;      // by source
  std::map<std::string, std::vector<Component>> components_;  // by source
  std::map<std::string, std::vector<Operation>> operations_;  // by source
  std::map<std::string, Offered> offered_;                    // by operation name
  std::map<std::string, Robot> robots_;                       // by "<space>/<robot>"
  std::string last_services_, last_components_, last_graph_;  // JSON last published
};

// The time of a stamp in seconds since the Unix epoch, and now.
double unix_seconds(std::chrono::system_clock::time_point time);
double unix_now();

Pose pose_of(const std::string& space, const std::string& robot, double x, double y, double theta,
             std::chrono::system_clock::time_point stamp, const char* via);

}  // namespace urs::gateway
