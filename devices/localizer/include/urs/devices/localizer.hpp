#pragma once
// The simulated global position sensor (a StarLITE-like ceiling-tag localizer) as a service agent
// implementing URC::Localization (idl/urc/Localization.idl); reference in docs/devices.md.
//
// Between start() and stop() it reads one robot's ground truth from the DDS topic
// "urs/world/pose", and `rate` times per simulated second adds Gaussian noise to the latest pose
// and publishes the measurement on "urs/localizer/pose" (the robot closes its loop on it) and as
// the event "<prefix>/pose" (URC::PoseWithCovariance).
// Tunable while it runs (agent::Tunable; as an RTC, its configuration parameters): `noise_xy`
// (m) and `noise_theta` (rad), with the ranges of their params; the next measurement uses them.

#include <yaml-cpp/yaml.h>

#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>

#include "Localization.pb.h"
#include "urs/agent/tunable.hpp"
#include "urs/agent/typed_agent.hpp"

namespace urs::world {
class World;
struct PoseSample;
}  // namespace urs::world

namespace urs::devices {

class SimLoop;

struct LocalizerConfig {
  std::string name = "localizer";  // DDS participant name
  std::string robot = "robot";     // the robot measured (its `name` param)
  std::string prefix;              // event topic prefix; empty = name
  uint32_t domain = 0;             // DDS domain id
  double time_scale = 1;           // simulated seconds per wall second; as the robot's
  double rate = 10;                // Hz of simulated time
  double noise_xy = 0.02;          // m, standard deviation on x and on y
  double noise_theta = 0.01;       // rad, standard deviation on theta
  std::string frame = "map";       // frame of reference reported with each pose
  uint32_t seed = 0;               // of the noise; 0 = a different one each run
};

// Throws urs::devices::ParamError (urs/devices/params.hpp) naming every bad key.
LocalizerConfig parse_localizer_config(const YAML::Node& params);

class LocalizerAgent : public agent::TypedAgent, public agent::Tunable {
 public:
  explicit LocalizerAgent(LocalizerConfig config);
  ~LocalizerAgent() override;

  void start(agent::EventSink& events) override;  // throws std::runtime_error if DDS fails
  void stop() override;

  // agent::Tunable
  std::vector<Parameter> tunable_parameters() const override;
  std::string check_parameter(const std::string& name, const std::string& value) const override;
  void set_parameter(const std::string& name, const std::string& value) override;

 private:
  void on_truth(const world::PoseSample& truth);
  void measure();

  const LocalizerConfig config_;
  mutable std::mutex mutex_;
  double noise_xy_;                           // m; tunable
  double noise_theta_;                        // rad; tunable
  std::unique_ptr<world::PoseSample> truth_;  // the latest ground truth, null until one arrived
  std::optional<URC::PoseWithCovariance> latest_;
  std::mt19937 random_;
  agent::EventSink* events_ = nullptr;
  std::unique_ptr<world::World> world_;
  std::unique_ptr<SimLoop> loop_;
};

std::shared_ptr<agent::ServiceAgent> make_localizer_agent(const YAML::Node& params);

}  // namespace urs::devices
