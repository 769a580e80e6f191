#pragma once
// The shared world state over Fast DDS: robots' ground-truth poses and localizers' measurements
// on plain typed topics (idl/dds/WorldState.idl), so devices in different processes, and readers
// from other DDS vendors, see the same world.
//
//   urs::world::World world(domain, "robot1");
//   world.subscribe(Channel::localizer, "robot1", [](const PoseSample& p) { ... });
//   world.publish(Channel::ground_truth, sample);
//
// QoS on both topics: reliable, keep-last 1 per robot, transient-local (late joiners get the
// latest pose). Transports: Fast DDS's defaults (UDPv4 and shared memory; in-process delivery
// between participants of one process).

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

namespace urs::world {

inline constexpr const char* kGroundTruthTopic = "urs/world/pose";    // urs::dds::RobotPose
inline constexpr const char* kLocalizerTopic = "urs/localizer/pose";  // urs::dds::RobotPoseEstimate

enum class Channel {
  ground_truth,  // kGroundTruthTopic: where a robot really is (the simulator's truth)
  localizer,     // kLocalizerTopic: where a localizer measured it, with covariance
};

struct PoseSample {
  std::string robot;                            // the DDS key: one instance per robot
  double x = 0;                                 // m
  double y = 0;                                 // m
  double theta = 0;                             // rad, counter-clockwise from +x
  std::array<double, 9> covariance{};           // row-major (x, y, theta); zero on ground truth
  std::chrono::system_clock::time_point stamp;  // wall clock, when written
  // Ground truth only: s of simulated time since the robot started. Motion measured against it
  // is exact whatever the machine's load (a late tick delays the sample, not its sim_time).
  double sim_time = 0;
};

// One DDS participant. Thread-safe. Handlers run on Fast DDS threads and must not block long.
class World {
 public:
  using Handler = std::function<void(const PoseSample&)>;

  // Throws std::runtime_error if the participant cannot be created (e.g. domain out of range).
  World(uint32_t domain, const std::string& participant_name);
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  // Writes on the channel's topic (the writer is created on first use); false if DDS refused.
  bool publish(Channel channel, const PoseSample& sample);

  // Calls `handler` for every sample about `robot` on the channel, starting with the latest one
  // already written (transient-local). Throws std::runtime_error if the reader cannot be made.
  void subscribe(Channel channel, const std::string& robot, Handler handler);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace urs::world
