#include "urs/camera/camera_agent.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <set>
#include <stdexcept>
#include <vector>

#include "urs/camera/image_codec.hpp"
#include "urs/camera/recognizer.hpp"
#include "urs/camera/world_pose.hpp"
#include "urs/devices/params.hpp"

namespace urs::camera {
namespace {

using agent::CallContext;
using agent::Outcome;
using devices::ParamError;
using devices::ParamReader;

Outcome not_ready(const std::string& reason) {
  auto exception = std::make_shared<URC::NotReady>();
  exception->set_reason(reason);
  return Outcome::raise(exception, "NotReady: " + reason);
}

Outcome invalid_argument(const std::string& parameter, const std::string& reason) {
  auto exception = std::make_shared<URC::InvalidArgument>();
  exception->set_parameter(parameter);
  exception->set_reason(reason);
  return Outcome::raise(exception, "InvalidArgument: " + parameter + ": " + reason);
}

}  // namespace

CameraParams parse_camera_params(const YAML::Node& params) {
  CameraParams out;
  World world = default_lab();
  CameraModel camera;
  ParamReader p("camera", params, {"device", "event_prefix", "scan_hz", "pose", "world", "camera", "room", "markers"});
  out.device = p.integer("device", out.device, 0u, 255u);
  out.event_prefix = p.text("event_prefix", out.event_prefix);
  out.scan_hz = p.number("scan_hz", out.scan_hz, 0, 30);
  if (auto pose = p.section("pose", {"x", "y", "theta"})) {
    out.pose.x = pose->number("x", out.pose.x, -1000, 1000);
    out.pose.y = pose->number("y", out.pose.y, -1000, 1000);
    out.pose.theta = pose->number("theta", out.pose.theta, -10, 10);
  }
  if (auto link = p.section("world", {"domain", "robot"})) {
    CameraParams::WorldLink world_link;
    world_link.domain = link->domain("domain", world_link.domain);
    if (!link->has("robot")) link->fail("robot", "required (the robot whose pose the camera rides on)");
    world_link.robot = link->text("robot", world_link.robot);
    if (p.has("pose")) p.fail("pose", "not allowed with world (the pose comes from the world state)");
    out.world = world_link;
  }
  if (auto model = p.section("camera", {"width", "height", "hfov_deg", "mount_height"})) {
    camera.width = model->integer("width", camera.width, 16u, 4096u);
    camera.height = model->integer("height", camera.height, 16u, 4096u);
    camera.hfov_deg = model->number("hfov_deg", camera.hfov_deg, 1, 179);
    camera.mount_height = model->number("mount_height", camera.mount_height, 0, 100);
  }
  if (auto room = p.section("room", {"width", "depth", "wall_height"})) {
    world.room.width = room->number("width", world.room.width, 0.1, 1000);
    world.room.depth = room->number("depth", world.room.depth, 0.1, 1000);
    world.room.wall_height = room->number("wall_height", world.room.wall_height, 0.1, 100);
  }
  if (p.has("markers")) {
    world.markers.clear();
    for (auto& entry : p.sections("markers", {"id", "x", "y", "z", "size"})) {
      for (const char* key : {"id", "x", "y"}) {
        if (!entry.has(key)) entry.fail(key, "required");
      }
      WallMarker m;
      m.id = entry.integer("id", m.id, 0, 1000000);
      m.x = entry.number("x", m.x, -1000, 1000);
      m.y = entry.number("y", m.y, -1000, 1000);
      m.z = entry.number("z", m.z, 0, 100);
      m.size = entry.number("size", m.size, 0.01, 10);
      world.markers.push_back(m);
    }
  }
  if (!p.failed()) {
    // What no single key's range expresses: every marker on a wall, fitting it, encodable.
    try {
      out.scene = std::make_shared<const Scene>(std::move(world), camera);
    } catch (const std::invalid_argument& e) {
      p.fail("markers", e.what());
    }
  }
  p.finish();
  return out;
}

CameraAgent::CameraAgent(CameraParams params, std::shared_ptr<PoseSource> poses)
    : TypedAgent(*URC::ImageRecognition_recognize_Request::descriptor()->file(), "ImageRecognition"),
      params_(std::move(params)),
      poses_(std::move(poses)) {
  if (!params_.scene || !poses_) throw std::invalid_argument("CameraAgent needs a scene and a pose source");
  on<URC::ImageRecognition_openCamera_Request, URC::ImageRecognition_openCamera_Reply>(
      "openCamera", [this](const auto& req, auto&, const CallContext&) {
        if (req.device() != params_.device) {
          return not_ready("no camera " + std::to_string(req.device()) + ": this simulated camera is device " +
                           std::to_string(params_.device));
        }
        open_ = true;
        return Outcome::ok();
      });
  on<URC::ImageRecognition_closeCamera_Request, URC::ImageRecognition_closeCamera_Reply>(
      "closeCamera", [this](const auto&, auto&, const CallContext&) {
        open_ = false;
        return Outcome::ok();
      });
  on<URC::ImageRecognition_captureImage_Request, URC::ImageRecognition_captureImage_Reply>(
      "captureImage", [this](const auto& req, auto& rep, const CallContext&) {
        // Checked before readiness: a bad argument is the caller's mistake whatever the camera's state.
        const int encoding = req.encoding();
        if (encoding != URC::IMAGE_ENCODING_RAW_RGB8 && encoding != URC::IMAGE_ENCODING_PNG) {
          return invalid_argument(
              "encoding", encoding_name(encoding) + " is not supported: the simulated camera delivers RAW_RGB8 or PNG");
        }
        std::string reason;
        const auto pose = ready(reason);
        if (!pose) return not_ready(reason);
        *rep.mutable_result() = capture(*pose, req.encoding());
        return Outcome::ok();
      });
  on<URC::ImageRecognition_getImageFormat_Request, URC::ImageRecognition_getImageFormat_Reply>(
      "getImageFormat", [this](const auto&, auto& rep, const CallContext&) {
        if (!open_) return not_ready("camera not open");
        rep.mutable_result()->set_width(params_.scene->camera().width);
        rep.mutable_result()->set_height(params_.scene->camera().height);
        rep.mutable_result()->set_encoding(URC::IMAGE_ENCODING_RAW_RGB8);
        return Outcome::ok();
      });
  on<URC::ImageRecognition_recognize_Request, URC::ImageRecognition_recognize_Reply>(
      "recognize", [this](const auto&, auto& rep, const CallContext& ctx) {
        std::string reason;
        const auto pose = ready(reason);
        if (!pose) return not_ready(reason);
        rep = recognize_at(*pose);
        const auto published = ctx.events->publish(params_.event_prefix + "/markers", rep);
        if (!published.ok()) spdlog::warn("camera: markers event dropped: {}", published.message);
        return Outcome::ok();
      });
  check_complete();
}

CameraAgent::~CameraAgent() { stop(); }

std::optional<Pose> CameraAgent::ready(std::string& reason) const {
  if (!open_) {
    reason = "camera not open";
    return std::nullopt;
  }
  auto pose = poses_->current();
  if (!pose) reason = "no robot pose known yet";
  return pose;
}

URC::Image CameraAgent::capture(const Pose& pose, URC::ImageEncoding encoding) const {
  const auto now =
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  RgbFrame frame = params_.scene->render(pose);
  URC::Image image;
  image.mutable_stamp()->set_sec(now / 1'000'000'000);
  image.mutable_stamp()->set_nsec(static_cast<uint32_t>(now % 1'000'000'000));
  image.mutable_format()->set_width(frame.width);
  image.mutable_format()->set_height(frame.height);
  image.mutable_format()->set_encoding(encoding);
  if (encoding == URC::IMAGE_ENCODING_PNG) {
    image.set_data(encode_png(frame));
  } else {
    image.set_data(std::string(frame.rgb.begin(), frame.rgb.end()));
  }
  return image;
}

URC::ImageRecognition_recognize_Reply CameraAgent::recognize_at(const Pose& pose) const {
  URC::ImageRecognition_recognize_Reply reply;
  for (auto& marker : find_markers(params_.scene->render(pose))) *reply.add_result() = std::move(marker);
  return reply;
}

void CameraAgent::start(agent::EventSink& events) {
  if (params_.scan_hz <= 0 || scanner_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = false;
  }
  scanner_ = std::thread([this, &events] { scan_loop(events); });
}

void CameraAgent::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (scanner_.joinable()) scanner_.join();
}

void CameraAgent::scan_loop(agent::EventSink& events) {
  const auto period = std::chrono::duration<double>(1.0 / params_.scan_hz);
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, period, [this] { return stopping_; });
    if (stopping_) break;
    lock.unlock();
    std::string reason;
    if (const auto pose = ready(reason)) {
      const auto published = events.publish(params_.event_prefix + "/markers", recognize_at(*pose));
      if (!published.ok()) spdlog::warn("camera: markers event dropped: {}", published.message);
    }
    lock.lock();
  }
}

std::shared_ptr<agent::ServiceAgent> make_camera_agent(const YAML::Node& params) {
  CameraParams parsed = parse_camera_params(params);
  std::shared_ptr<PoseSource> poses;
  if (parsed.world) {
    try {
      poses = std::make_shared<WorldPoseSource>(parsed.world->domain, parsed.world->robot);
    } catch (const std::runtime_error& e) {
      throw ParamError("camera", {{"world", e.what()}});
    }
  } else {
    poses = std::make_shared<FixedPose>(parsed.pose);
  }
  return std::make_shared<CameraAgent>(std::move(parsed), std::move(poses));
}

}  // namespace urs::camera
