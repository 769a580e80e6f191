#include "urs/camera/world_pose.hpp"

namespace urs::camera {

WorldPoseSource::WorldPoseSource(uint32_t domain, const std::string& robot)
    : world_(std::make_unique<world::World>(domain, "camera-" + robot)) {
  world_->subscribe(world::Channel::ground_truth, robot, [latest = latest_](const world::PoseSample& sample) {
    std::lock_guard<std::mutex> lock(latest->mutex);
    latest->pose = Pose{sample.x, sample.y, sample.theta};
  });
}

std::optional<Pose> WorldPoseSource::current() {
  std::lock_guard<std::mutex> lock(latest_->mutex);
  return latest_->pose;
}

}  // namespace urs::camera
