#pragma once
// A PoseSource fed by the shared world state: the robot's ground-truth pose on the DDS topic
// "urs/world/pose" (urs::world), so the camera sees what the simulated robot drives past.

#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "urs/camera/camera_agent.hpp"
#include "urs/world/world.hpp"

namespace urs::camera {

class WorldPoseSource : public PoseSource {
 public:
  // Subscribes to `robot`'s ground truth; the latest sample already written arrives at once
  // (transient-local). Throws std::runtime_error if DDS refuses the participant or the reader.
  WorldPoseSource(uint32_t domain, const std::string& robot);
  std::optional<Pose> current() override;

 private:
  struct Latest {
    std::mutex mutex;
    std::optional<Pose> pose;
  };
  // Shared with the DDS handler, which the world keeps for as long as it lives.
  std::shared_ptr<Latest> latest_ = std::make_shared<Latest>();
  std::unique_ptr<world::World> world_;
};

}  // namespace urs::camera
