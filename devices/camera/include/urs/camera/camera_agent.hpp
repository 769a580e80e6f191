#pragma once
// The camera + image recognition device: a service agent implementing URC::ImageRecognition
// (idl/urc/ImageRecognition.idl) on a simulated camera that renders the room around the robot's
// pose. Hosted by urs-sam as an SA or by urs-rtc-manager as an RTC; no middleware code here.
//
// Events: every recognition (a recognize() call, or the periodic scan when scan_hz > 0) publishes
// "<event_prefix>/markers" carrying a URC::ImageRecognition_recognize_Reply.

#include <yaml-cpp/yaml.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "ImageRecognition.pb.h"
#include "urs/agent/typed_agent.hpp"
#include "urs/camera/scene.hpp"

namespace urs::camera {

// Where the camera learns the robot's pose. Called from worker threads, concurrently.
class PoseSource {
 public:
  virtual ~PoseSource() = default;
  // The current pose, or nullopt while none is known (the camera then answers NotReady).
  virtual std::optional<Pose> current() = 0;
};

class FixedPose : public PoseSource {
 public:
  explicit FixedPose(Pose pose) : pose_(pose) {}
  std::optional<Pose> current() override { return pose_; }

 private:
  Pose pose_;
};

struct CameraParams {
  std::shared_ptr<const Scene> scene;  // the room, its markers and the camera model
  Pose pose{3.25, 2.0, 0.0};           // fixed pose, used unless `world` is set
  struct WorldLink {
    uint32_t domain = 0;  // DDS domain of the world state
    std::string robot;    // whose ground-truth pose the camera rides on
  };
  std::optional<WorldLink> world;  // take the pose from "urs/world/pose" instead
  unsigned device = 0;             // the only device number openCamera() accepts
  std::string event_prefix = "camera";
  double scan_hz = 0;  // > 0: recognise and publish this often while open
};

// Reads the agent's `params` node (null = all defaults; see docs/devices.md). Throws
// urs::devices::ParamError listing every bad key with its value.
CameraParams parse_camera_params(const YAML::Node& params);

class CameraAgent : public agent::TypedAgent {
 public:
  // `params.scene` must be set; `poses` must not be null.
  CameraAgent(CameraParams params, std::shared_ptr<PoseSource> poses);
  ~CameraAgent() override;

  void start(agent::EventSink& events) override;
  void stop() override;

 private:
  // NotReady reason when the camera cannot take a picture now, else the pose to take it from.
  std::optional<Pose> ready(std::string& reason) const;
  URC::Image capture(const Pose& pose, URC::ImageEncoding encoding) const;
  URC::ImageRecognition_recognize_Reply recognize_at(const Pose& pose) const;
  void scan_loop(agent::EventSink& events);

  CameraParams params_;
  std::shared_ptr<PoseSource> poses_;
  std::atomic<bool> open_{false};
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread scanner_;
};

// A CameraAgent on a FixedPose, or on a WorldPoseSource when params name a `world`. Throws
// urs::devices::ParamError for bad params (and, keyed "world", if DDS refuses the world's
// participant).
std::shared_ptr<agent::ServiceAgent> make_camera_agent(const YAML::Node& params);

}  // namespace urs::camera
