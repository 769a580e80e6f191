#pragma once
// The simulated mobile base (a Pioneer P3DX-like unicycle) as a service agent implementing
// URC::Navigation (idl/urc/Navigation.idl). Hosted by urs-sam as an SA or by urs-rtc-manager as
// an RTC; reference in docs/devices.md.
//
// Between start() and stop() it runs a 50 Hz control loop on simulated time, publishes its
// ground-truth pose on the DDS topic "urs/world/pose" (key: its name), and closes its loop on a
// localizer's measurements of it from "urs/localizer/pose", fused with wheel odometry.
// Events: "<prefix>/arrived" (URC::Navigation_moveTo_Request: the target reached) and
// "<prefix>/state" (URC::Navigation__get_state_Reply: the new state).
// Tunable while it runs (agent::Tunable; as an RTC, its configuration parameters): `speed`
// (mm/s, as setSpeed), `tolerance` (m) and `fusion_gain`, with the ranges of their params.

#include <yaml-cpp/yaml.h>

#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "urs/agent/tunable.hpp"
#include "urs/agent/typed_agent.hpp"
#include "urs/devices/robot_motion.hpp"

namespace urs::world {
class World;
}  // namespace urs::world

namespace urs::devices {

class SimLoop;

struct RobotConfig {
  enum class Feedback {
    localizer,     // the estimate is odometry corrected by the localizer's fixes (the papers' setup)
    ground_truth,  // the estimate is the truth: a base that knows where it is, no localizer needed
  };
  std::string name = "robot";  // DDS key of its poses; the localizer's `robot` param names it
  std::string prefix;          // event topic prefix; empty = name
  uint32_t domain = 0;         // DDS domain id
  double time_scale = 1;       // simulated seconds per wall second
  Pose2 start;                 // initial ground-truth pose
  MotionLimits limits;
  double speed = 0.5;            // m/s, initial cruise speed
  double tolerance = 0.02;       // m, arrival distance (of the estimate to the target)
  double odometry_error = 0.01;  // relative scale error of the wheel odometry
  double fusion_gain = 0.2;      // weight of one localizer fix in the estimate
  Feedback feedback = Feedback::localizer;
};

// Throws urs::devices::ParamError (urs/devices/params.hpp) naming every bad key.
RobotConfig parse_robot_config(const YAML::Node& params);

class RobotAgent : public agent::TypedAgent, public agent::Tunable {
 public:
  static constexpr double kControlPeriod = 0.02;  // s of simulated time (50 Hz)

  explicit RobotAgent(RobotConfig config);
  ~RobotAgent() override;

  void start(agent::EventSink& events) override;  // throws std::runtime_error if DDS fails
  void stop() override;

  // Where the base really is and how fast it moves, for tests and the simulator's own use.
  struct Truth {
    Pose2 pose;
    Velocity velocity;
    double time = 0;  // s of simulated time since start()
  };
  Truth truth() const;

  // agent::Tunable
  std::vector<Parameter> tunable_parameters() const override;
  std::string check_parameter(const std::string& name, const std::string& value) const override;
  void set_parameter(const std::string& name, const std::string& value) override;

 private:
  struct Pending;  // events produced under the lock, published after it
  void tick();
  void on_fix(const Pose2& fix);
  // Runs `fn` under the lock, then publishes the events it produced.
  agent::Outcome change(const std::function<agent::Outcome(Pending&)>& fn);
  int driving_state() const;  // with a target: MOVING, or STOPPED at a zero cruise speed
  void set_state(int state, Pending& pending);
  void publish(const Pending& pending);

  const RobotConfig config_;
  mutable std::mutex mutex_;
  Truth truth_;
  PoseEstimate estimate_;
  std::optional<Pose2> target_;
  double cruise_;       // m/s
  double tolerance_;    // m; tunable
  double fusion_gain_;  // tunable
  int state_;           // URC::NavigationState
  agent::EventSink* events_ = nullptr;
  std::unique_ptr<world::World> world_;
  std::unique_ptr<SimLoop> loop_;
};

std::shared_ptr<agent::ServiceAgent> make_robot_agent(const YAML::Node& params);

}  // namespace urs::devices
