#pragma once
// WorldSource: the robots' poses straight from the gateway's own space's devices domain
// (idl/dds/WorldState.idl: urs/localizer/pose or urs/world/pose), every sample as the localizer
// (or the simulator) writes it — what the bridge relays to other spaces only every period.
// Threads: poses are reported on Fast DDS's listener threads.

#include <memory>
#include <string>
#include <vector>

#include "urs/gateway/space_view.hpp"

namespace urs::world {
class World;
}

namespace urs::gateway {

struct WorldSourceOptions {
  std::string space;
  uint32_t domain = 1;
  bool ground_truth = false;        // false: the localizers' measurements
  std::vector<std::string> robots;  // the robots' names
};

class WorldSource : public SpaceSource {
 public:
  explicit WorldSource(WorldSourceOptions options);
  ~WorldSource() override;

  // Joins the devices' domain; throws std::runtime_error if DDS refuses.
  void start(ViewSink& sink) override;
  void stop() override;

 private:
  const WorldSourceOptions options_;
  std::unique_ptr<world::World> world_;
};

}  // namespace urs::gateway
