#pragma once
// The simulated base's motion, free of threads and DDS so that it can be tested alone: a unicycle
// with acceleration limits, a go-to-goal controller, and the pose estimate the controller uses
// (wheel odometry corrected by localizer fixes).

namespace urs::devices {

struct Pose2 {
  double x = 0;      // m
  double y = 0;      // m
  double theta = 0;  // rad, in (-pi, pi]
};

struct Velocity {
  double v = 0;  // m/s, forward
  double w = 0;  // rad/s, counter-clockwise
};

struct MotionLimits {
  double max_speed = 1.2;       // m/s (P3DX: 1.2)
  double max_accel = 0.5;       // m/s^2, also the braking limit
  double max_turn_rate = 1.75;  // rad/s (100 deg/s)
  double max_turn_accel = 3.5;  // rad/s^2
};

double wrap_angle(double a);  // into (-pi, pi]

// The velocity to command for driving from `at` to (tx, ty) at up to `cruise` m/s: turns in place
// while the target is far off the heading, then drives while steering, braking early enough to
// stop on the target within the limits.
Velocity go_to_goal(const Pose2& at, double tx, double ty, double cruise, const MotionLimits& limits);

// `current` moved towards `command` within the acceleration limits over `dt` s, and clamped to
// the speed limits.
Velocity ramp(const Velocity& current, const Velocity& command, const MotionLimits& limits, double dt);

// The pose after driving at `velocity` for `dt` s (exact on arcs).
Pose2 integrate(const Pose2& pose, const Velocity& velocity, double dt);

// Dead reckoning from odometry, pulled towards each localizer fix by `gain` (0 ignores fixes, 1
// jumps to them): a complementary filter whose estimate is smoother than the fixes, since
// wheel odometry is precise over a short time and a localizer is unbiased over a long one.
class PoseEstimate {
 public:
  bool valid() const { return valid_; }
  const Pose2& pose() const { return pose_; }
  void reset(const Pose2& pose) {
    pose_ = pose;
    valid_ = true;
  }
  void predict(const Velocity& odometry, double dt);  // no-op until valid
  void correct(const Pose2& fix, double gain);        // the first fix sets the estimate

 private:
  Pose2 pose_;
  bool valid_ = false;
};

}  // namespace urs::devices
