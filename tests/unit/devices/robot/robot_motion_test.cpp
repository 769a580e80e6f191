// The robot's motion model, controller and pose estimate, without threads or DDS.

#include "urs/devices/robot_motion.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace {

using urs::devices::go_to_goal;
using urs::devices::integrate;
using urs::devices::MotionLimits;
using urs::devices::Pose2;
using urs::devices::PoseEstimate;
using urs::devices::ramp;
using urs::devices::Velocity;
using urs::devices::wrap_angle;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDt = 0.02;

TEST(RobotMotion, WrapAngleKeepsHeadingsInMinusPiToPi) {
  EXPECT_NEAR(wrap_angle(3 * kPi / 2), -kPi / 2, 1e-12);
  EXPECT_NEAR(wrap_angle(-3 * kPi / 2), kPi / 2, 1e-12);
  EXPECT_NEAR(wrap_angle(-kPi), kPi, 1e-12);
  EXPECT_NEAR(wrap_angle(0.5), 0.5, 1e-12);
}

TEST(RobotMotion, RampNeverChangesFasterThanTheLimitsAllow) {
  MotionLimits limits;
  Velocity v;
  v = ramp(v, Velocity{5, 10}, limits, kDt);
  EXPECT_NEAR(v.v, limits.max_accel * kDt, 1e-12);
  EXPECT_NEAR(v.w, limits.max_turn_accel * kDt, 1e-12);
  for (int i = 0; i < 1000; ++i) v = ramp(v, Velocity{5, 10}, limits, kDt);
  EXPECT_DOUBLE_EQ(v.v, limits.max_speed);
  EXPECT_DOUBLE_EQ(v.w, limits.max_turn_rate);
  v = ramp(v, Velocity{0, 0}, limits, kDt);
  EXPECT_NEAR(v.v, limits.max_speed - limits.max_accel * kDt, 1e-12);
}

TEST(RobotMotion, IntegrateFollowsStraightLinesAndArcs) {
  Pose2 p = integrate(Pose2{1, 2, kPi / 2}, Velocity{0.5, 0}, 2);
  EXPECT_NEAR(p.x, 1, 1e-12);
  EXPECT_NEAR(p.y, 3, 1e-12);
  // A quarter circle of radius 1 from the origin heading +x ends at (1, 1) heading +y.
  p = integrate(Pose2{0, 0, 0}, Velocity{kPi / 2, kPi / 2}, 1);
  EXPECT_NEAR(p.x, 1, 1e-12);
  EXPECT_NEAR(p.y, 1, 1e-12);
  EXPECT_NEAR(p.theta, kPi / 2, 1e-12);
}

// Drives with the truth as feedback until the controller is within `tolerance`; returns the
// distance at rest and checks the limits on every step.
double drive(Pose2 start, double tx, double ty, double cruise, double tolerance) {
  MotionLimits limits;
  Pose2 pose = start;
  Velocity v;
  bool arrived = false;
  for (int step = 0; step < 100000 && !(arrived && v.v == 0 && v.w == 0); ++step) {
    Velocity cmd;
    if (!arrived && std::hypot(tx - pose.x, ty - pose.y) <= tolerance) arrived = true;
    if (!arrived) cmd = go_to_goal(pose, tx, ty, cruise, limits);
    EXPECT_LE(std::abs(cmd.v), cruise + 1e-12);
    const Velocity next = ramp(v, cmd, limits, kDt);
    EXPECT_LE(std::abs(next.v - v.v), limits.max_accel * kDt + 1e-12);
    v = next;
    pose = integrate(pose, v, kDt);
  }
  EXPECT_TRUE(arrived);
  return std::hypot(tx - pose.x, ty - pose.y);
}

TEST(RobotMotion, GoToGoalStopsWithinTheToleranceFromAnyHeading) {
  for (double heading : {0.0, kPi / 2, kPi, -2.5}) {
    EXPECT_LT(drive(Pose2{0, 0, heading}, 3, -2, 0.8, 0.02), 0.025) << "heading " << heading;
  }
  EXPECT_LT(drive(Pose2{0, 0, 0}, 0.05, 0, 1.2, 0.02), 0.025);
}

TEST(RobotMotion, GoToGoalTurnsInPlaceWhenTheTargetIsBehind) {
  const Velocity cmd = go_to_goal(Pose2{0, 0, 0}, -2, 0.1, 0.5, MotionLimits());
  EXPECT_EQ(cmd.v, 0);
  EXPECT_GT(cmd.w, 0);  // the shorter way round: counter-clockwise towards +y
}

TEST(RobotMotion, EstimateStartsAtTheFirstFixThenBlends) {
  PoseEstimate estimate;
  estimate.predict(Velocity{1, 0}, 1);
  EXPECT_FALSE(estimate.valid());
  estimate.correct(Pose2{1, 1, 0}, 0.2);
  ASSERT_TRUE(estimate.valid());
  EXPECT_DOUBLE_EQ(estimate.pose().x, 1);
  estimate.correct(Pose2{2, 1, 0}, 0.2);
  EXPECT_NEAR(estimate.pose().x, 1.2, 1e-12);
  // Blending headings goes the short way across +-pi.
  estimate.reset(Pose2{0, 0, kPi - 0.1});
  estimate.correct(Pose2{0, 0, -kPi + 0.1}, 0.5);
  EXPECT_NEAR(std::abs(estimate.pose().theta), kPi, 1e-12);
}

TEST(RobotMotion, EstimateIsSmootherThanNoisyFixes) {
  std::mt19937 random(1);
  std::normal_distribution<double> noise(0, 0.02);
  PoseEstimate estimate;
  estimate.reset(Pose2{0, 0, 0});
  double sum_sq = 0;
  const int n = 2000;
  for (int i = 0; i < n; ++i) {
    estimate.correct(Pose2{noise(random), 0, 0}, 0.2);
    sum_sq += estimate.pose().x * estimate.pose().x;
  }
  // Steady state of the blend: variance gain / (2 - gain) of the fixes' = (0.0067 m)^2.
  EXPECT_LT(std::sqrt(sum_sq / n), 0.01);
}

}  // namespace
