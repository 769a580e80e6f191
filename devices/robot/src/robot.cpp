#include "urs/devices/robot.hpp"

#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

#include "Navigation.pb.h"
#include "urs/devices/params.hpp"
#include "urs/devices/sim_loop.hpp"
#include "urs/util/number.hpp"
#include "urs/world/world.hpp"

namespace urs::devices {

using agent::CallContext;
using agent::Outcome;

namespace {

constexpr double kMaxSpeedLimit = 1200;  // mm/s, the P3DX's top speed

std::shared_ptr<URC::NotReady> not_ready(const std::string& reason) {
  auto e = std::make_shared<URC::NotReady>();
  e->set_reason(reason);
  return e;
}

}  // namespace

struct RobotAgent::Pending {
  std::optional<Pose2> arrived;  // the target just reached
  std::optional<int> state;      // the state just entered
};

RobotConfig parse_robot_config(const YAML::Node& params) {
  ParamReader p("robot", params,
                {"name", "prefix", "domain", "time_scale", "x", "y", "theta", "speed", "max_speed", "max_accel",
                 "max_turn_rate", "max_turn_accel", "tolerance", "odometry_error", "fusion_gain", "feedback"});
  RobotConfig c;
  c.name = p.text("name", c.name);
  c.prefix = p.text("prefix", c.name);
  c.domain = p.domain("domain", c.domain);
  c.time_scale = p.number("time_scale", c.time_scale, 0.01, 100);
  c.start.x = p.number("x", 0, -1e6, 1e6);
  c.start.y = p.number("y", 0, -1e6, 1e6);
  c.start.theta = wrap_angle(p.number("theta", 0, -10, 10));
  c.limits.max_speed = p.number("max_speed", kMaxSpeedLimit, 1, kMaxSpeedLimit) / 1000;
  c.speed = p.number("speed", c.speed * 1000, 0, c.limits.max_speed * 1000) / 1000;
  c.limits.max_accel = p.number("max_accel", c.limits.max_accel, 0.05, 5);
  c.limits.max_turn_rate = p.number("max_turn_rate", c.limits.max_turn_rate, 0.1, 6.3);
  c.limits.max_turn_accel = p.number("max_turn_accel", c.limits.max_turn_accel, 0.1, 20);
  c.tolerance = p.number("tolerance", c.tolerance, 0.005, 1);
  c.odometry_error = p.number("odometry_error", c.odometry_error, 0, 0.2);
  c.fusion_gain = p.number("fusion_gain", c.fusion_gain, 0, 1);
  if (p.choice("feedback", "localizer", {"localizer", "ground_truth"}) == "ground_truth") {
    c.feedback = RobotConfig::Feedback::ground_truth;
  }
  p.finish();
  return c;
}

RobotAgent::RobotAgent(RobotConfig config)
    : TypedAgent(*URC::Navigation_moveTo_Request::descriptor()->file(), "Navigation"),
      config_(std::move(config)),
      cruise_(config_.speed),
      tolerance_(config_.tolerance),
      fusion_gain_(config_.fusion_gain),
      state_(URC::NAVIGATION_STATE_IDLE),
      loop_(std::make_unique<SimLoop>()) {
  truth_.pose = config_.start;
  if (config_.feedback == RobotConfig::Feedback::ground_truth) estimate_.reset(truth_.pose);

  on<URC::Navigation_moveTo_Request, URC::Navigation_moveTo_Reply>(
      "moveTo", [this](const auto& req, auto&, const CallContext&) {
        if (!std::isfinite(req.x()) || !std::isfinite(req.y())) {
          auto e = std::make_shared<URC::InvalidTarget>();
          e->set_x(req.x());
          e->set_y(req.y());
          e->set_reason("the target must be finite numbers of metres");
          return Outcome::raise(e, "InvalidTarget: " + e->reason());
        }
        return change([&](Pending& pending) {
          if (!estimate_.valid()) return Outcome::raise(not_ready("no pose from the localizer yet"), "NotReady");
          target_ = Pose2{req.x(), req.y(), 0};
          set_state(driving_state(), pending);
          return Outcome::ok();
        });
      });
  on<URC::Navigation_getPosition_Request, URC::Navigation_getPosition_Reply>(
      "getPosition", [this](const auto&, auto& rep, const CallContext&) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!estimate_.valid()) return Outcome::raise(not_ready("no pose from the localizer yet"), "NotReady");
        rep.mutable_result()->set_x(estimate_.pose().x);
        rep.mutable_result()->set_y(estimate_.pose().y);
        rep.mutable_result()->set_theta(estimate_.pose().theta);
        return Outcome::ok();
      });
  on<URC::Navigation_stop_Request, URC::Navigation_stop_Reply>("stop", [this](const auto&, auto&, const CallContext&) {
    return change([&](Pending& pending) {
      target_.reset();
      if (state_ == URC::NAVIGATION_STATE_MOVING) set_state(URC::NAVIGATION_STATE_STOPPED, pending);
      return Outcome::ok();
    });
  });
  on<URC::Navigation_setSpeed_Request, URC::Navigation_setSpeed_Reply>(
      "setSpeed", [this](const auto& req, auto&, const CallContext&) {
        const double max_mm = config_.limits.max_speed * 1000;
        if (req.speed() > max_mm) {
          auto e = std::make_shared<URC::InvalidArgument>();
          e->set_parameter("speed");
          std::ostringstream reason;
          reason << req.speed() << " mm/s is above max_speed " << max_mm << " mm/s";
          e->set_reason(reason.str());
          return Outcome::raise(e, "InvalidArgument: speed: " + e->reason());
        }
        return change([&](Pending& pending) {
          cruise_ = req.speed() / 1000.0;
          if (target_) set_state(driving_state(), pending);
          return Outcome::ok();
        });
      });
  on<URC::Navigation__get_speed_Request, URC::Navigation__get_speed_Reply>(
      "_get_speed", [this](const auto&, auto& rep, const CallContext&) {
        std::lock_guard<std::mutex> lock(mutex_);
        rep.set_result(static_cast<uint32_t>(std::lround(cruise_ * 1000)));
        return Outcome::ok();
      });
  on<URC::Navigation__get_max_speed_Request, URC::Navigation__get_max_speed_Reply>(
      "_get_max_speed", [this](const auto&, auto& rep, const CallContext&) {
        rep.set_result(static_cast<uint32_t>(std::lround(config_.limits.max_speed * 1000)));
        return Outcome::ok();
      });
  on<URC::Navigation__get_state_Request, URC::Navigation__get_state_Reply>(
      "_get_state", [this](const auto&, auto& rep, const CallContext&) {
        std::lock_guard<std::mutex> lock(mutex_);
        rep.set_result(static_cast<URC::NavigationState>(state_));
        return Outcome::ok();
      });
  check_complete();
}

RobotAgent::~RobotAgent() { stop(); }

void RobotAgent::start(agent::EventSink& events) {
  events_ = &events;
  world_ = std::make_unique<world::World>(config_.domain, "urs-robot-" + config_.name);
  if (config_.feedback == RobotConfig::Feedback::localizer) {
    world_->subscribe(world::Channel::localizer, config_.name, [this](const world::PoseSample& s) {
      on_fix(Pose2{s.x, s.y, s.theta});
    });
  }
  loop_->start(kControlPeriod, config_.time_scale, [this] { tick(); });
}

void RobotAgent::stop() {
  loop_->stop();
  world_.reset();
}

RobotAgent::Truth RobotAgent::truth() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return truth_;
}

void RobotAgent::tick() {
  Pending pending;
  world::PoseSample sample;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Velocity command;
    if (target_ && state_ == URC::NAVIGATION_STATE_MOVING) {
      const Pose2& at = estimate_.pose();
      if (std::hypot(target_->x - at.x, target_->y - at.y) <= tolerance_) {
        pending.arrived = target_;
        target_.reset();
        set_state(URC::NAVIGATION_STATE_ARRIVED, pending);
      } else {
        command = go_to_goal(at, target_->x, target_->y, cruise_, config_.limits);
      }
    }
    truth_.velocity = ramp(truth_.velocity, command, config_.limits, kControlPeriod);
    truth_.pose = integrate(truth_.pose, truth_.velocity, kControlPeriod);
    truth_.time += kControlPeriod;
    if (config_.feedback == RobotConfig::Feedback::ground_truth) {
      estimate_.reset(truth_.pose);
    } else {
      // Wheel odometry: the true motion, misread by the encoders' scale error.
      const double scale = 1 + config_.odometry_error;
      estimate_.predict(Velocity{truth_.velocity.v * scale, truth_.velocity.w * scale}, kControlPeriod);
    }
    sample.robot = config_.name;
    sample.x = truth_.pose.x;
    sample.y = truth_.pose.y;
    sample.theta = truth_.pose.theta;
    sample.sim_time = truth_.time;
  }
  sample.stamp = std::chrono::system_clock::now();
  world_->publish(world::Channel::ground_truth, sample);
  publish(pending);
}

void RobotAgent::on_fix(const Pose2& fix) {
  std::lock_guard<std::mutex> lock(mutex_);
  estimate_.correct(fix, fusion_gain_);
}

// ---- agent::Tunable: the ranges are those of parse_robot_config ----

namespace {

struct Range {
  double min;
  double max;
};

}  // namespace

std::vector<agent::Tunable::Parameter> RobotAgent::tunable_parameters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return {{"speed", util::format_number(cruise_ * 1000)},
          {"tolerance", util::format_number(tolerance_)},
          {"fusion_gain", util::format_number(fusion_gain_)}};
}

std::string RobotAgent::check_parameter(const std::string& name, const std::string& value) const {
  const std::map<std::string, Range> ranges = {
      {"speed", {0, config_.limits.max_speed * 1000}}, {"tolerance", {0.005, 1}}, {"fusion_gain", {0, 1}}};
  const auto range = ranges.find(name);
  if (range == ranges.end()) return "the robot has no tunable parameter '" + name + "'";
  double ignored = 0;
  return util::read_number(value, range->second.min, range->second.max, ignored);
}

void RobotAgent::set_parameter(const std::string& name, const std::string& value) {
  const std::string why = check_parameter(name, value);
  if (!why.empty()) throw std::invalid_argument(name + ": " + why);
  const double number = *util::parse_number(value);
  change([&](Pending& pending) {
    if (name == "speed") {
      cruise_ = number / 1000;  // as setSpeed: the state follows
      if (target_) set_state(driving_state(), pending);
    } else if (name == "tolerance") {
      tolerance_ = number;
    } else {
      fusion_gain_ = number;
    }
    return Outcome::ok();
  });
}

Outcome RobotAgent::change(const std::function<Outcome(Pending&)>& fn) {
  Pending pending;
  Outcome outcome;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    outcome = fn(pending);
  }
  publish(pending);
  return outcome;
}

int RobotAgent::driving_state() const {
  return cruise_ > 0 ? URC::NAVIGATION_STATE_MOVING : URC::NAVIGATION_STATE_STOPPED;
}

void RobotAgent::set_state(int state, Pending& pending) {
  if (state == state_) return;
  state_ = state;
  pending.state = state;
}

void RobotAgent::publish(const Pending& pending) {
  if (events_ == nullptr) return;
  // A full event queue drops the event; the state stays readable through _get_state.
  if (pending.state) {
    URC::Navigation__get_state_Reply event;
    event.set_result(static_cast<URC::NavigationState>(*pending.state));
    events_->publish(config_.prefix + "/state", event);
  }
  if (pending.arrived) {
    URC::Navigation_moveTo_Request event;
    event.set_x(pending.arrived->x);
    event.set_y(pending.arrived->y);
    events_->publish(config_.prefix + "/arrived", event);
  }
}

std::shared_ptr<agent::ServiceAgent> make_robot_agent(const YAML::Node& params) {
  return std::make_shared<RobotAgent>(parse_robot_config(params));
}

}  // namespace urs::devices
