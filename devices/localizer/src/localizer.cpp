#include "urs/devices/localizer.hpp"

#include <cmath>
#include <stdexcept>

#include "urs/devices/params.hpp"
#include "urs/devices/robot_motion.hpp"
#include "urs/devices/sim_loop.hpp"
#include "urs/util/number.hpp"
#include "urs/world/world.hpp"

namespace urs::devices {

using agent::CallContext;
using agent::Outcome;

LocalizerConfig parse_localizer_config(const YAML::Node& params) {
  ParamReader p(
      "localizer", params,
      {"name", "robot", "prefix", "domain", "time_scale", "rate", "noise_xy", "noise_theta", "frame", "seed"});
  LocalizerConfig c;
  c.name = p.text("name", c.name);
  c.robot = p.text("robot", c.robot);
  c.prefix = p.text("prefix", c.name);
  c.domain = p.domain("domain", c.domain);
  c.time_scale = p.number("time_scale", c.time_scale, 0.01, 100);
  c.rate = p.number("rate", c.rate, 0.1, 100);
  c.noise_xy = p.number("noise_xy", c.noise_xy, 0, 10);
  c.noise_theta = p.number("noise_theta", c.noise_theta, 0, 3);
  c.frame = p.text("frame", c.frame);
  c.seed = p.integer<uint32_t>("seed", 0, 0, 4294967295u);
  p.finish();
  return c;
}

LocalizerAgent::LocalizerAgent(LocalizerConfig config)
    : TypedAgent(*URC::Localization_getPose_Request::descriptor()->file(), "Localization"),
      config_(std::move(config)),
      noise_xy_(config_.noise_xy),
      noise_theta_(config_.noise_theta),
      random_(config_.seed != 0 ? config_.seed : std::random_device{}()),
      loop_(std::make_unique<SimLoop>()) {
  on<URC::Localization_getPose_Request, URC::Localization_getPose_Reply>(
      "getPose", [this](const auto&, auto& rep, const CallContext&) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!latest_) {
          auto e = std::make_shared<URC::NotReady>();
          e->set_reason("no pose of robot '" + config_.robot + "' measured yet");
          return Outcome::raise(e, "NotReady: " + e->reason());
        }
        *rep.mutable_result() = *latest_;
        return Outcome::ok();
      });
  on<URC::Localization__get_rate_Request, URC::Localization__get_rate_Reply>(
      "_get_rate", [this](const auto&, auto& rep, const CallContext&) {
        rep.set_result(config_.rate);
        return Outcome::ok();
      });
  check_complete();
}

LocalizerAgent::~LocalizerAgent() { stop(); }

void LocalizerAgent::start(agent::EventSink& events) {
  events_ = &events;
  world_ = std::make_unique<world::World>(config_.domain, "urs-localizer-" + config_.name);
  world_->subscribe(world::Channel::ground_truth, config_.robot, [this](const world::PoseSample& s) { on_truth(s); });
  loop_->start(1 / config_.rate, config_.time_scale, [this] { measure(); });
}

void LocalizerAgent::stop() {
  loop_->stop();
  world_.reset();
}

void LocalizerAgent::on_truth(const world::PoseSample& truth) {
  std::lock_guard<std::mutex> lock(mutex_);
  truth_ = std::make_unique<world::PoseSample>(truth);
}

void LocalizerAgent::measure() {
  world::PoseSample fix;
  URC::PoseWithCovariance pose;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!truth_) return;  // no tag in view yet: the robot has not published
    std::normal_distribution<double> xy(0, noise_xy_);
    std::normal_distribution<double> theta(0, noise_theta_);
    fix.robot = config_.robot;
    fix.x = truth_->x + xy(random_);
    fix.y = truth_->y + xy(random_);
    fix.theta = wrap_angle(truth_->theta + theta(random_));
    fix.covariance[0] = fix.covariance[4] = noise_xy_ * noise_xy_;
    fix.covariance[8] = noise_theta_ * noise_theta_;
    fix.stamp = std::chrono::system_clock::now();

    pose.set_x(fix.x);
    pose.set_y(fix.y);
    pose.set_theta(fix.theta);
    for (double c : fix.covariance) pose.add_covariance(c);
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(fix.stamp.time_since_epoch()).count();
    pose.mutable_stamp()->set_sec(ns / 1'000'000'000);
    pose.mutable_stamp()->set_nsec(static_cast<uint32_t>(ns % 1'000'000'000));
    pose.set_frame(config_.frame);
    latest_ = pose;
  }
  world_->publish(world::Channel::localizer, fix);
  // A full event queue drops this pose; the next one follows within 1/rate.
  events_->publish(config_.prefix + "/pose", pose);
}

// ---- agent::Tunable: the ranges are those of parse_localizer_config ----

std::vector<agent::Tunable::Parameter> LocalizerAgent::tunable_parameters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return {{"noise_xy", util::format_number(noise_xy_)}, {"noise_theta", util::format_number(noise_theta_)}};
}

std::string LocalizerAgent::check_parameter(const std::string& name, const std::string& value) const {
  double ignored = 0;
  if (name == "noise_xy") return util::read_number(value, 0, 10, ignored);
  if (name == "noise_theta") return util::read_number(value, 0, 3, ignored);
  return "the localizer has no tunable parameter '" + name + "'";
}

void LocalizerAgent::set_parameter(const std::string& name, const std::string& value) {
  const std::string why = check_parameter(name, value);
  if (!why.empty()) throw std::invalid_argument(name + ": " + why);
  std::lock_guard<std::mutex> lock(mutex_);
  (name == "noise_xy" ? noise_xy_ : noise_theta_) = *util::parse_number(value);
}

std::shared_ptr<agent::ServiceAgent> make_localizer_agent(const YAML::Node& params) {
  return std::make_shared<LocalizerAgent>(parse_localizer_config(params));
}

}  // namespace urs::devices
