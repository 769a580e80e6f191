#include "urs/devices/robot_motion.hpp"

#include <algorithm>
#include <cmath>

namespace urs::devices {

namespace {

constexpr double kPi = 3.14159265358979323846;
// Beyond this bearing error the base turns in place first: driving on would swing wide arcs.
constexpr double kTurnInPlace = 0.35;  // rad (20 deg)
// Proportional gains near the goal, so speed and turn rate fade out instead of dithering.
constexpr double kSpeedGain = 1.5;  // (m/s) per m
constexpr double kTurnGain = 3.0;   // (rad/s) per rad

double approach(double value, double target, double step) {
  return value < target ? std::min(target, value + step) : std::max(target, value - step);
}

}  // namespace

double wrap_angle(double a) {
  a = std::remainder(a, 2 * kPi);
  return a <= -kPi ? a + 2 * kPi : a;
}

Velocity go_to_goal(const Pose2& at, double tx, double ty, double cruise, const MotionLimits& limits) {
  const double dx = tx - at.x;
  const double dy = ty - at.y;
  const double distance = std::hypot(dx, dy);
  const double bearing = wrap_angle(std::atan2(dy, dx) - at.theta);
  Velocity cmd;
  // Turn rate that can still be braked to zero within the remaining angle.
  const double turn = std::min(
      {limits.max_turn_rate, std::sqrt(2 * limits.max_turn_accel * std::abs(bearing)), kTurnGain * std::abs(bearing)});
  cmd.w = std::copysign(turn, bearing);
  if (std::abs(bearing) < kTurnInPlace) {
    const double speed =
        std::min({cruise, limits.max_speed, std::sqrt(2 * limits.max_accel * distance), kSpeedGain * distance});
    cmd.v = speed * std::cos(bearing);
  }
  return cmd;
}

Velocity ramp(const Velocity& current, const Velocity& command, const MotionLimits& limits, double dt) {
  Velocity next;
  next.v = std::clamp(approach(current.v, command.v, limits.max_accel * dt), -limits.max_speed, limits.max_speed);
  next.w = std::clamp(approach(current.w, command.w, limits.max_turn_accel * dt), -limits.max_turn_rate,
                      limits.max_turn_rate);
  return next;
}

Pose2 integrate(const Pose2& pose, const Velocity& velocity, double dt) {
  Pose2 next = pose;
  const double dtheta = velocity.w * dt;
  if (std::abs(dtheta) < 1e-9) {
    next.x += velocity.v * dt * std::cos(pose.theta);
    next.y += velocity.v * dt * std::sin(pose.theta);
  } else {
    const double r = velocity.v / velocity.w;
    next.x += r * (std::sin(pose.theta + dtheta) - std::sin(pose.theta));
    next.y -= r * (std::cos(pose.theta + dtheta) - std::cos(pose.theta));
  }
  next.theta = wrap_angle(pose.theta + dtheta);
  return next;
}

void PoseEstimate::predict(const Velocity& odometry, double dt) {
  if (valid_) pose_ = integrate(pose_, odometry, dt);
}

void PoseEstimate::correct(const Pose2& fix, double gain) {
  if (!valid_) {
    reset(fix);
    return;
  }
  pose_.x += gain * (fix.x - pose_.x);
  pose_.y += gain * (fix.y - pose_.y);
  pose_.theta = wrap_angle(pose_.theta + gain * wrap_angle(fix.theta - pose_.theta));
}

}  // namespace urs::devices
