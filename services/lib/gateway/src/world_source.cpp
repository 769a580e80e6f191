#include "urs/gateway/world_source.hpp"

#include "urs/gateway/gateway.hpp"
#include "urs/world/world.hpp"

namespace urs::gateway {

WorldSource::WorldSource(WorldSourceOptions options) : options_(std::move(options)) {}

WorldSource::~WorldSource() { stop(); }

void WorldSource::start(ViewSink& sink) {
  world_ = std::make_unique<world::World>(options_.domain, "urs-gateway/" + options_.space + "/poses");
  const auto channel = options_.ground_truth ? world::Channel::ground_truth : world::Channel::localizer;
  for (const auto& robot : options_.robots) {
    world_->subscribe(channel, robot, [this, &sink](const world::PoseSample& sample) {
      sink.pose(pose_of(options_.space, sample.robot, sample.x, sample.y, sample.theta, sample.stamp, "devices"));
    });
  }
}

void WorldSource::stop() { world_.reset(); }

}  // namespace urs::gateway
