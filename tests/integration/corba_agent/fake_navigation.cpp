#include "fake_navigation.hpp"

#include <cmath>
#include <mutex>

#include "Navigation.pb.h"
#include "urs/agent/typed_agent.hpp"

namespace urs::test {
namespace {

using agent::CallContext;
using agent::Outcome;

class FakeNavigation : public agent::TypedAgent {
 public:
  FakeNavigation() : TypedAgent(*URC::Navigation_moveTo_Request::descriptor()->file(), "Navigation") {
    on<URC::Navigation_moveTo_Request, URC::Navigation_moveTo_Reply>(
        "moveTo", [this](const auto& req, auto&, const CallContext& ctx) {
          if (!std::isfinite(req.x()) || !std::isfinite(req.y()) || std::hypot(req.x(), req.y()) > 100) {
            auto refused = std::make_shared<URC::InvalidTarget>();
            refused->set_x(req.x());
            refused->set_y(req.y());
            refused->set_reason("farther than 100 m");
            return Outcome::raise(refused, "InvalidTarget");
          }
          URC::Pose2D pose;
          {
            std::lock_guard lock(mutex_);
            pose_.set_x(req.x());
            pose_.set_y(req.y());
            state_ = URC::NAVIGATION_STATE_MOVING;
            pose = pose_;
          }
          ctx.events->publish("pose", pose);
          return Outcome::ok();
        });
    on<URC::Navigation_getPosition_Request, URC::Navigation_getPosition_Reply>(
        "getPosition", [this](const auto&, auto& rep, const CallContext&) {
          std::lock_guard lock(mutex_);
          *rep.mutable_result() = pose_;
          return Outcome::ok();
        });
    on<URC::Navigation_stop_Request, URC::Navigation_stop_Reply>("stop",
                                                                 [this](const auto&, auto&, const CallContext&) {
                                                                   std::lock_guard lock(mutex_);
                                                                   state_ = URC::NAVIGATION_STATE_STOPPED;
                                                                   return Outcome::ok();
                                                                 });
    on<URC::Navigation_setSpeed_Request, URC::Navigation_setSpeed_Reply>(
        "setSpeed", [this](const auto& req, auto&, const CallContext&) {
          if (req.speed() > kMaxSpeed) {
            auto refused = std::make_shared<URC::InvalidArgument>();
            refused->set_parameter("speed");
            refused->set_reason("at most 800 mm/s");
            return Outcome::raise(refused, "InvalidArgument");
          }
          std::lock_guard lock(mutex_);
          speed_ = req.speed();
          return Outcome::ok();
        });
    on<URC::Navigation__get_speed_Request, URC::Navigation__get_speed_Reply>(
        "_get_speed", [this](const auto&, auto& rep, const CallContext&) {
          std::lock_guard lock(mutex_);
          rep.set_result(speed_);
          return Outcome::ok();
        });
    on<URC::Navigation__get_max_speed_Request, URC::Navigation__get_max_speed_Reply>(
        "_get_max_speed", [](const auto&, auto& rep, const CallContext&) {
          rep.set_result(kMaxSpeed);
          return Outcome::ok();
        });
    on<URC::Navigation__get_state_Request, URC::Navigation__get_state_Reply>(
        "_get_state", [this](const auto&, auto& rep, const CallContext&) {
          std::lock_guard lock(mutex_);
          rep.set_result(state_);
          return Outcome::ok();
        });
    check_complete();
  }

 private:
  static constexpr std::uint32_t kMaxSpeed = 800;
  std::mutex mutex_;
  URC::Pose2D pose_;
  std::uint32_t speed_ = 200;
  URC::NavigationState state_ = URC::NAVIGATION_STATE_IDLE;
};

}  // namespace

std::shared_ptr<agent::ServiceAgent> make_fake_navigation() { return std::make_shared<FakeNavigation>(); }

}  // namespace urs::test
