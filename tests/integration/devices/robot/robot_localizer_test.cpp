// The simulated robot and localizer as agents in one process, each with its own Fast DDS
// participant: the robot publishes its ground truth, the localizer measures it with noise, and
// the robot's controller closes its loop on the measurements. Simulated time runs ten times
// faster than the wall clock; the wall-clock limits below only catch a hang.

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "Localization.pb.h"
#include "Navigation.pb.h"
#include "dds_domain.hpp"
#include "urs/devices/localizer.hpp"
#include "urs/devices/robot.hpp"

namespace {

using urs::agent::CallContext;
using urs::agent::Outcome;
using urs::agent::ServiceAgent;
using urs::devices::RobotAgent;

constexpr auto kHang = std::chrono::seconds(120);

class RecordingSink : public urs::agent::EventSink {
 public:
  urs::call::Reply publish(const std::string& topic, const google::protobuf::Message& event) override {
    std::lock_guard<std::mutex> lock(mutex_);
    events_.push_back({topic, std::shared_ptr<google::protobuf::Message>(event.New())});
    events_.back().second->CopyFrom(event);
    return {};
  }
  std::vector<std::shared_ptr<google::protobuf::Message>> on(const std::string& topic) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<std::shared_ptr<google::protobuf::Message>> found;
    for (const auto& [t, e] : events_) {
      if (t == topic) found.push_back(e);
    }
    return found;
  }

 private:
  std::mutex mutex_;
  std::vector<std::pair<std::string, std::shared_ptr<google::protobuf::Message>>> events_;
};

Outcome call(ServiceAgent& agent, const std::string& operation, const google::protobuf::Message& request,
             google::protobuf::Message& reply) {
  RecordingSink unused;
  CallContext ctx;
  ctx.deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  ctx.events = &unused;
  return agent.invoke(*agent.interface().FindMethodByName(operation), request, reply, ctx);
}

// Polls `done` every millisecond; false after kHang.
bool eventually(const std::function<bool()>& done) {
  const auto until = std::chrono::steady_clock::now() + kHang;
  while (!done()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

URC::NavigationState state_of(RobotAgent& robot) {
  URC::Navigation__get_state_Reply reply;
  call(robot, "_get_state", URC::Navigation__get_state_Request(), reply);
  return reply.result();
}

Outcome set_speed(RobotAgent& robot, uint32_t mm_per_s) {
  URC::Navigation_setSpeed_Request request;
  request.set_speed(mm_per_s);
  URC::Navigation_setSpeed_Reply reply;
  return call(robot, "setSpeed", request, reply);
}

Outcome move_to(RobotAgent& robot, double x, double y) {
  URC::Navigation_moveTo_Request request;
  request.set_x(x);
  request.set_y(y);
  URC::Navigation_moveTo_Reply reply;
  return call(robot, "moveTo", request, reply);
}

// Samples the robot's ground truth on its own thread until destroyed.
class Recorder {
 public:
  struct Sample {
    RobotAgent::Truth truth;
    int phase;
  };
  explicit Recorder(RobotAgent& robot)
      : thread_([this, &robot] {
          while (!stop_) {
            Sample s{robot.truth(), phase.load()};
            {
              std::lock_guard<std::mutex> lock(mutex_);
              if (samples_.empty() || s.truth.time > samples_.back().truth.time) samples_.push_back(s);
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
          }
        }) {}
  ~Recorder() {
    stop_ = true;
    thread_.join();
  }
  std::vector<Sample> samples() {
    std::lock_guard<std::mutex> lock(mutex_);
    return samples_;
  }
  std::atomic<int> phase{0};  // a label the test sets; recorded with each sample

 private:
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::vector<Sample> samples_;
  std::thread thread_;
};

class RobotLocalizerTest : public ::testing::Test {
 protected:
  // Tests of this file may run at once (ctest -j): each uses its own robot name and domain.
  const std::string robot_name_ = "p3dx-" + std::to_string(::getpid());
  const urs::test::DdsDomains domains_{1};
  const uint32_t domain_ = domains_[0];

  // Each *_yaml adds ", key: value" pairs to the device's params.
  void start(const std::string& robot_yaml, const std::string& localizer_yaml) {
    robot_ = std::make_shared<RobotAgent>(urs::devices::parse_robot_config(YAML::Load(
        "{name: " + robot_name_ + ", domain: " + std::to_string(domain_) + ", time_scale: 10" + robot_yaml + "}")));
    localizer_ = urs::devices::make_localizer_agent(YAML::Load("{name: starlite, robot: " + robot_name_ +
                                                               ", domain: " + std::to_string(domain_) +
                                                               ", time_scale: 10, seed: 7" + localizer_yaml + "}"));
    localizer_->start(localizer_events_);
    robot_->start(robot_events_);
    // The robot knows where it is once the localizer's first fix has reached it.
    ASSERT_TRUE(eventually([&] {
      URC::Navigation_getPosition_Reply reply;
      return call(*robot_, "getPosition", URC::Navigation_getPosition_Request(), reply).status == urs::call::Status::OK;
    }));
  }

  void TearDown() override {
    if (robot_) robot_->stop();
    if (localizer_) localizer_->stop();
  }

  RecordingSink robot_events_;
  RecordingSink localizer_events_;
  std::shared_ptr<RobotAgent> robot_;
  std::shared_ptr<ServiceAgent> localizer_;
};

TEST_F(RobotLocalizerTest, SquarePathWithTheLocalizerInTheLoopEndsWithin5cmOfEveryWaypoint) {
  start(", x: 0.5, y: 0.5, theta: 0, speed: 500", "");
  const std::vector<std::pair<double, double>> waypoints = {{1.5, 1.0}, {1.5, 3.0}, {5.0, 3.0}, {5.0, 1.0}, {1.5, 1.0}};
  Recorder recorder(*robot_);
  std::vector<double> errors;
  for (const auto& [x, y] : waypoints) {
    ASSERT_EQ(move_to(*robot_, x, y).status, urs::call::Status::OK);
    ASSERT_TRUE(eventually([&] { return state_of(*robot_) == URC::NAVIGATION_STATE_ARRIVED; }))
        << "never arrived at (" << x << ", " << y << ")";
    // The controller declares arrival on its estimate; the truth is where the base comes to rest.
    ASSERT_TRUE(eventually([&] { return robot_->truth().velocity.v == 0; }));
    const auto truth = robot_->truth();
    errors.push_back(std::hypot(truth.pose.x - x, truth.pose.y - y));
    std::printf("waypoint (%.1f, %.1f): rest at (%.4f, %.4f), error %.1f mm, t = %.2f s\n", x, y, truth.pose.x,
                truth.pose.y, errors.back() * 1000, truth.time);
  }
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    EXPECT_LT(errors[i], 0.05) << "waypoint " << i;
  }

  const std::string trace = ::testing::TempDir() + "/robot_square_trace.csv";
  std::ofstream csv(trace);
  csv << "time,x,y\n";
  for (const auto& s : recorder.samples())
    csv << s.truth.time << "," << s.truth.pose.x << "," << s.truth.pose.y << "\n";
  std::printf("trace: %s\n", trace.c_str());

  const auto arrived = robot_events_.on(robot_name_ + "/arrived");
  ASSERT_EQ(arrived.size(), waypoints.size());
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    const auto& target = static_cast<const URC::Navigation_moveTo_Request&>(*arrived[i]);
    EXPECT_EQ(target.x(), waypoints[i].first);
    EXPECT_EQ(target.y(), waypoints[i].second);
  }
  const auto poses = localizer_events_.on("starlite/pose");
  ASSERT_FALSE(poses.empty());
  const auto& pose = static_cast<const URC::PoseWithCovariance&>(*poses.back());
  ASSERT_EQ(pose.covariance_size(), 9);
  EXPECT_DOUBLE_EQ(pose.covariance(0), 0.02 * 0.02);
  EXPECT_DOUBLE_EQ(pose.covariance(8), 0.01 * 0.01);
  EXPECT_EQ(pose.frame(), "map");
}

TEST_F(RobotLocalizerTest, SpeedChangesAreFollowedWithinTheAccelerationLimit) {
  start(", x: 0, y: 0, theta: 0, speed: 200, max_accel: 0.5", "");
  Recorder recorder(*robot_);
  ASSERT_EQ(move_to(*robot_, 40, 0).status, urs::call::Status::OK);
  const std::vector<uint32_t> commands = {200, 800, 500, 0};
  for (std::size_t i = 0; i < commands.size(); ++i) {
    recorder.phase = static_cast<int>(i);
    ASSERT_EQ(set_speed(*robot_, commands[i]).status, urs::call::Status::OK);
    const double target = commands[i] / 1000.0;
    ASSERT_TRUE(eventually([&] { return std::abs(robot_->truth().velocity.v - target) < 0.002; }))
        << "speed never reached " << commands[i] << " mm/s";
    // Hold the speed for one simulated second, so that a drift away from it would show.
    const double until = robot_->truth().time + 1.0;
    ASSERT_TRUE(eventually([&] { return robot_->truth().time > until; }));
    EXPECT_NEAR(robot_->truth().velocity.v, target, 0.002) << "at " << commands[i] << " mm/s";
  }
  EXPECT_EQ(state_of(*robot_), URC::NAVIGATION_STATE_STOPPED);

  const auto samples = recorder.samples();
  ASSERT_GT(samples.size(), 100u);
  double max_accel = 0;
  for (std::size_t i = 1; i < samples.size(); ++i) {
    const auto& a = samples[i - 1].truth;
    const auto& b = samples[i].truth;
    const double accel = std::abs(b.velocity.v - a.velocity.v) / (b.time - a.time);
    max_accel = std::max(max_accel, accel);
    ASSERT_LE(accel, 0.5 + 1e-9) << "at t = " << b.time;
    // While changing from one command to the next, the speed stays between them.
    const int phase = samples[i].phase;
    const double bound = std::max(commands[phase], phase > 0 ? commands[phase - 1] : 0u) / 1000.0;
    ASSERT_LE(b.velocity.v, bound + 1e-9) << "at t = " << b.time;
    ASSERT_GE(b.velocity.v, 0) << "at t = " << b.time;
  }
  std::printf("%zu samples, largest acceleration %.3f m/s^2 (limit 0.5)\n", samples.size(), max_accel);
}

TEST_F(RobotLocalizerTest, BadInputsRaiseTheirIdlExceptions) {
  // A localizer watching a robot that never publishes has nothing to report.
  auto lonely = urs::devices::make_localizer_agent(
      YAML::Load("{name: lonely, robot: nobody, time_scale: 10, domain: " + std::to_string(domain_) + "}"));
  RecordingSink sink;
  lonely->start(sink);
  URC::Localization_getPose_Reply pose;
  auto outcome = call(*lonely, "getPose", URC::Localization_getPose_Request(), pose);
  ASSERT_EQ(outcome.status, urs::call::Status::USER_EXCEPTION);
  EXPECT_EQ(outcome.exception->GetDescriptor(), URC::NotReady::descriptor());
  lonely->stop();

  start("", "");
  outcome = set_speed(*robot_, 5000);
  ASSERT_EQ(outcome.status, urs::call::Status::USER_EXCEPTION);
  const auto* invalid = dynamic_cast<const URC::InvalidArgument*>(outcome.exception.get());
  ASSERT_NE(invalid, nullptr);
  EXPECT_EQ(invalid->parameter(), "speed");
  EXPECT_NE(invalid->reason().find("1200"), std::string::npos) << invalid->reason();

  outcome = move_to(*robot_, std::nan(""), 1.0);
  ASSERT_EQ(outcome.status, urs::call::Status::USER_EXCEPTION);
  EXPECT_EQ(outcome.exception->GetDescriptor(), URC::InvalidTarget::descriptor());
  EXPECT_EQ(state_of(*robot_), URC::NAVIGATION_STATE_IDLE);

  URC::Navigation__get_max_speed_Reply max_speed;
  ASSERT_EQ(call(*robot_, "_get_max_speed", URC::Navigation__get_max_speed_Request(), max_speed).status,
            urs::call::Status::OK);
  EXPECT_EQ(max_speed.result(), 1200u);
}

}  // namespace
