// The robot's and localizer's params: defaults, and every mistake named by its key.

#include <gtest/gtest.h>

#include <string>

#include "urs/devices/localizer.hpp"
#include "urs/devices/robot.hpp"
#include "urs/util/cli.hpp"

namespace {

using urs::devices::parse_localizer_config;
using urs::devices::parse_robot_config;
using urs::devices::RobotConfig;

std::string robot_error(const std::string& yaml) {
  try {
    parse_robot_config(YAML::Load(yaml));
  } catch (const urs::util::ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(DeviceParams, RobotDefaultsAreAP3dxClosingItsLoopOnTheLocalizer) {
  const RobotConfig c = parse_robot_config(YAML::Node());
  EXPECT_EQ(c.name, "robot");
  EXPECT_EQ(c.prefix, "robot");
  EXPECT_EQ(c.domain, 0u);
  EXPECT_DOUBLE_EQ(c.limits.max_speed, 1.2);
  EXPECT_DOUBLE_EQ(c.speed, 0.5);
  EXPECT_EQ(c.feedback, RobotConfig::Feedback::localizer);
  const RobotConfig named = parse_robot_config(YAML::Load("{name: p3dx, max_speed: 800, speed: 200, feedback: ground_truth}"));
  EXPECT_EQ(named.prefix, "p3dx");
  EXPECT_DOUBLE_EQ(named.limits.max_speed, 0.8);
  EXPECT_DOUBLE_EQ(named.speed, 0.2);
  EXPECT_EQ(named.feedback, RobotConfig::Feedback::ground_truth);
}

TEST(DeviceParams, RobotMistakesAreAllNamedByKey) {
  const std::string error = robot_error("{speed: 5000, domain: 1.5, feedback: gps, wheels: 4, time_scale: .nan}");
  EXPECT_NE(error.find("5 error"), std::string::npos) << error;
  EXPECT_NE(error.find("robot.speed"), std::string::npos) << error;
  EXPECT_NE(error.find("robot.domain"), std::string::npos) << error;
  EXPECT_NE(error.find("robot.feedback: 'gps'"), std::string::npos) << error;
  EXPECT_NE(error.find("robot.wheels: unknown key"), std::string::npos) << error;
  EXPECT_NE(error.find("robot.time_scale"), std::string::npos) << error;
  EXPECT_NE(robot_error("[1, 2]").find("params must be a map"), std::string::npos);
  EXPECT_NE(robot_error("{max_speed: 1500}").find("robot.max_speed: 1500 is outside 1 .. 1200"), std::string::npos);
}

TEST(DeviceParams, LocalizerDefaultsAndMistakes) {
  const auto c = parse_localizer_config(YAML::Node());
  EXPECT_EQ(c.robot, "robot");
  EXPECT_EQ(c.prefix, "localizer");
  EXPECT_DOUBLE_EQ(c.rate, 10);
  EXPECT_DOUBLE_EQ(c.noise_xy, 0.02);
  EXPECT_DOUBLE_EQ(c.noise_theta, 0.01);
  try {
    parse_localizer_config(YAML::Load("{rate: 0, robot: ''}"));
    FAIL() << "accepted a zero rate";
  } catch (const urs::util::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("localizer.rate: 0 is outside"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("localizer.robot: must not be empty"), std::string::npos) << e.what();
  }
}

}  // namespace
