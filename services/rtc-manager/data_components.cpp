// Counter and Sink: a writer and a reader of data ports, so that a deployment can check data-port
// connections (URSLink's or OpenRTM-aist's ports at either end) end to end.

#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <cmath>

#include "BasicDataType.hh"
#include "ExtendedDataTypes.hh"
#include "components.hpp"
#include "urs/rtc/data_port.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/number.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::rtc_manager {
namespace {

RTC::Time now() {
  const auto since_epoch = std::chrono::system_clock::now().time_since_epoch();
  const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(since_epoch);
  RTC::Time time;
  time.sec = static_cast<CORBA::ULong>(seconds.count());
  const auto nanoseconds = std::chrono::duration_cast<std::chrono::nanoseconds>(since_epoch - seconds);
  time.nsec = static_cast<CORBA::ULong>(nanoseconds.count());
  return time;
}

struct CounterSettings {
  CORBA::Long start = 0;
  double radius_m = 1.0;
  double period_s = 10.0;  // one turn of the circle
};

// While active, writes start, start+1, ... on "count" and a point going round a circle (heading along it)
// on "pose" once per execution. Configuration: `radius` (m) and `period` (s per turn) may change
// at any time, and the next execution uses them; `start` is read-only.
class CounterComponent : public rtc::Component {
 public:
  explicit CounterComponent(const CounterSettings& settings)
      : Component({"Counter", "Writes a counter and a pose on a circle to data ports", "1.0.0", "URSLink", "Data"}),
        settings_(settings),
        count_port_("count"),
        pose_port_("pose"),
        radius_m_(settings.radius_m),
        period_s_(settings.period_s),
        count_(settings.start) {}

 protected:
  RTC::ReturnCode_t handle_initialize() override {
    declare_parameter("start", std::to_string(settings_.start));
    declare_parameter({"radius", util::format_number(settings_.radius_m), rtc::number_between(0, 1e6),
                       [this](const std::string& value) { radius_m_ = *util::parse_number(value); }});
    declare_parameter({"period", util::format_number(settings_.period_s), rtc::number_between(1e-3, 1e6),
                       [this](const std::string& value) { period_s_ = *util::parse_number(value); }});
    add_port(count_port_);
    add_port(pose_port_);
    return RTC::RTC_OK;
  }

  RTC::ReturnCode_t handle_activated(RTC::ExecutionContextHandle_t) override {
    activated_at_ = std::chrono::steady_clock::now();
    return RTC::RTC_OK;
  }

  RTC::ReturnCode_t handle_execute(RTC::ExecutionContextHandle_t) override {
    RTC::TimedLong count;
    count.tm = now();
    count.data = count_;
    // Wraps at 2^31 instead of overflowing.
    count_ = static_cast<CORBA::Long>(static_cast<CORBA::ULong>(count_) + 1);
    count_port_.write(count);

    constexpr double kTurn = 2 * M_PI;
    const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - activated_at_;
    const double radius = radius_m_;
    const double angle = std::fmod(elapsed.count() / period_s_, 1.0) * kTurn;
    RTC::TimedPose2D pose;
    pose.tm = count.tm;
    pose.data.position.x = radius * std::cos(angle);
    pose.data.position.y = radius * std::sin(angle);
    pose.data.heading = std::remainder(angle + kTurn / 4, kTurn);
    pose_port_.write(pose);
    return RTC::RTC_OK;
  }

  RTC::ReturnCode_t handle_deactivated(RTC::ExecutionContextHandle_t) override {
    spdlog::info("{}: next count {}", instance_name(), count_);
    return RTC::RTC_OK;
  }

 private:
  const CounterSettings settings_;
  rtc::OutPort<RTC::TimedLong> count_port_;
  rtc::OutPort<RTC::TimedPose2D> pose_port_;
  std::atomic<double> radius_m_;  // set by tools in ORB threads, read by the execution context
  std::atomic<double> period_s_;
  CORBA::Long count_;  // touched by the execution context's thread only
  std::chrono::steady_clock::time_point activated_at_;
};

// Logs every value that arrives (debug) and how many did (at deactivation and exit).
class SinkComponent : public rtc::Component {
 public:
  explicit SinkComponent(std::size_t buffer_length)
      : Component({"Sink", "Receives a counter and a pose from data ports", "1.0.0", "URSLink", "Data"}),
        count_port_("count", buffer_length),
        pose_port_("pose", buffer_length) {}

 protected:
  RTC::ReturnCode_t handle_initialize() override {
    count_port_.on_receive([this](const RTC::TimedLong& value) {
      spdlog::debug("{}: count {} (t={}.{:09})", instance_name(), value.data, value.tm.sec, value.tm.nsec);
    });
    pose_port_.on_receive([this](const RTC::TimedPose2D& value) {
      spdlog::debug("{}: pose x={:.3f} y={:.3f} heading={:.3f} (t={}.{:09})", instance_name(), value.data.position.x,
                    value.data.position.y, value.data.heading, value.tm.sec, value.tm.nsec);
    });
    add_port(count_port_);
    add_port(pose_port_);
    return RTC::RTC_OK;
  }

  // Values arrive whether or not the Sink is active, so the tally also comes at exit.
  RTC::ReturnCode_t handle_deactivated(RTC::ExecutionContextHandle_t) override { return report(); }
  RTC::ReturnCode_t handle_finalize() override { return report(); }

 private:
  RTC::ReturnCode_t report() {
    spdlog::info("{}: received {} counts and {} poses", instance_name(), count_port_.received(), pose_port_.received());
    return RTC::RTC_OK;
  }

  rtc::InPort<RTC::TimedLong> count_port_;
  rtc::InPort<RTC::TimedPose2D> pose_port_;
};

}  // namespace

std::unique_ptr<rtc::Component> make_counter(const YAML::Node& config, const rtc::ComponentEnv&) {
  CounterSettings settings;
  std::vector<std::string> errors;
  if (config) {
    util::check_keys(config, "config", {"start", "radius", "period"}, errors);
    if (config["start"]) util::read_scalar(config["start"], "config.start", settings.start, errors);
    if (config["radius"]) util::read_scalar(config["radius"], "config.radius", settings.radius_m, errors);
    if (config["period"] && util::read_scalar(config["period"], "config.period", settings.period_s, errors) &&
        !(settings.period_s > 0)) {
      errors.push_back("config.period: must be > 0 (seconds per turn)");
    }
  }
  if (!errors.empty()) throw util::ConfigError(errors.front());
  return std::make_unique<CounterComponent>(settings);
}

std::unique_ptr<rtc::Component> make_sink(const YAML::Node& config, const rtc::ComponentEnv&) {
  int buffer_length = 64;
  std::vector<std::string> errors;
  if (config) {
    util::check_keys(config, "config", {"buffer"}, errors);
    if (config["buffer"] && util::read_scalar(config["buffer"], "config.buffer", buffer_length, errors) &&
        buffer_length < 1) {
      errors.push_back("config.buffer: must be >= 1 (values per port)");
    }
  }
  if (!errors.empty()) throw util::ConfigError(errors.front());
  return std::make_unique<SinkComponent>(static_cast<std::size_t>(buffer_length));
}

}  // namespace urs::rtc_manager
