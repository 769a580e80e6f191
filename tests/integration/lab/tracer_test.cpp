// urs-lab's Tracer on a real Fast DDS domain: the robot's ground truth is traced on the robot's
// simulated clock (the sim_time its poses carry), so what the experiments measure from the trace
// does not depend on when the samples arrive. On a loaded machine the robot's ticks come late and
// in bursts; stamped with their arrival, the same motion measured anything but its speed.

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "dds_domain.hpp"
#include "experiments.hpp"
#include "urs/world/world.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;

constexpr double kTick = 0.02;  // s of simulated time between poses (the robot's 50 Hz)
constexpr double kSpeed = 0.5;  // m/s of simulated time

world::PoseSample pose_at(int tick) {
  world::PoseSample pose;
  pose.robot = "r";
  pose.sim_time = 10.0 + tick * kTick;  // the robot started before the tracer
  pose.x = 1.0 + kSpeed * tick * kTick;
  pose.y = 2.0;
  pose.stamp = std::chrono::system_clock::now();
  return pose;
}

TEST(Tracer, StampsPosesWithTheRobotsSimulatedTimeHoweverLateTheyArrive) {
  const DdsDomains domains;
  world::World robot(domains[0], "robot");
  ASSERT_TRUE(robot.publish(world::Channel::ground_truth, pose_at(0)));
  lab::Tracer tracer(domains[0], "r", 10);  // returns once the first pose is traced

  // A loaded machine's robot: ticks written in bursts of ten, each burst after a stall of the
  // wall clock (the stall is the load being imitated, not a wait for anything).
  constexpr int kTicks = 150;
  for (int tick = 1; tick <= kTicks; ++tick) {
    ASSERT_TRUE(robot.publish(world::Channel::ground_truth, pose_at(tick)));
    if (tick % 10 == 0) std::this_thread::sleep_for(60ms);
  }
  ASSERT_TRUE(tracer.wait_until(kTicks * kTick - 1e-9, 20s)) << "traced up to t = " << tracer.now();
  EXPECT_NEAR(tracer.now(), kTicks * kTick, 1e-9) << "the tracer's clock is the robot's, not the wall clock";
  EXPECT_FALSE(tracer.wait_until(kTicks * kTick + 1, 50ms)) << "no pose of that time was written";

  const auto trace = tracer.samples();
  ASSERT_GE(trace.size(), 10u);  // keep-last 1: a burst may reach the reader as its last pose only
  EXPECT_EQ(trace.front().t, 0.0);
  for (const auto& sample : trace) {
    EXPECT_NEAR(sample.x - 1.0, kSpeed * sample.t, 1e-9) << "at t = " << sample.t;
  }
  const auto speeds = lab::speed_profile(trace, 0.2);
  ASSERT_FALSE(speeds.empty());
  for (const auto& [t, mm_s] : speeds) EXPECT_NEAR(mm_s, kSpeed * 1000, 1e-6) << "at t = " << t;
}

TEST(SpeedProfile, MeasuresOverTheWindowAndSkipsGapsTooShortToTell) {
  std::vector<lab::Sample> trace;
  for (int i = 0; i <= 50; ++i) trace.push_back({i * 0.02, i < 25 ? i * 0.004 : 0.1 + (i - 25) * 0.016, 0});
  const auto speeds = lab::speed_profile(trace, 0.2);
  ASSERT_FALSE(speeds.empty());
  EXPECT_NEAR(speeds.front().second, 200, 1e-6);  // 4 mm per 20 ms
  EXPECT_NEAR(speeds.back().second, 800, 1e-6);   // 16 mm per 20 ms
  EXPECT_TRUE(lab::speed_profile({{0, 0, 0}, {0.01, 1, 0}}, 0.2).empty()) << "10 ms is below a quarter window";
}

}  // namespace
}  // namespace urs::test
