#include "urs/camera/camera_agent.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <set>
#include <stdexcept>
#include <vector>

#include "urs/camera/image_codec.hpp"
#include "urs/camera/recognizer.hpp"
#include "urs/camera/world_pose.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::camera {
namespace {

using agent::CallContext;
using agent::Outcome;

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

// True if `node` is present and a map; appends errors for a non-map and for unknown keys.
bool present_map(const YAML::Node& node, const std::string& where, const std::set<std::string>& allowed,
                 std::vector<std::string>& errors) {
  if (!node) return false;
  if (!node.IsMap()) {
    errors.push_back(where + ": must be a map");
    return false;
  }
  util::check_keys(node, where, allowed, errors);
  return true;
}

// Reads those of the listed keys of the map `node` that are present into their targets.
template <class T>
void read_present(const YAML::Node& node, const std::string& where,
                  const std::vector<std::pair<const char*, T*>>& fields, std::vector<std::string>& errors) {
  for (const auto& [key, target] : fields) {
    if (node[key]) util::read_scalar(node[key], where + "." + key, *target, errors);
  }
}

}  // namespace

CameraParams parse_camera_params(const YAML::Node& params) {
  CameraParams out;
  World world = default_lab();
  CameraModel camera;
  std::vector<std::string> errors;
  if (params && !params.IsNull()) {
    if (!params.IsMap()) throw util::ConfigError("camera params: must be a map");
    util::check_keys(params, "", {"device", "event_prefix", "scan_hz", "pose", "world", "camera", "room", "markers"}, errors);
    if (params["device"]) util::read_scalar(params["device"], "device", out.device, errors);
    if (params["event_prefix"]) util::read_scalar(params["event_prefix"], "event_prefix", out.event_prefix, errors);
    if (params["scan_hz"]) util::read_scalar(params["scan_hz"], "scan_hz", out.scan_hz, errors);
    if (out.scan_hz < 0 || out.scan_hz > 30) errors.push_back("scan_hz: must be in 0..30");
    if (out.event_prefix.empty()) errors.push_back("event_prefix: must not be empty");
    if (present_map(params["pose"], "pose", {"x", "y", "theta"}, errors)) {
      read_present<double>(params["pose"], "pose", {{"x", &out.pose.x}, {"y", &out.pose.y}, {"theta", &out.pose.theta}},
                           errors);
    }
    if (present_map(params["world"], "world", {"domain", "robot"}, errors)) {
      CameraParams::WorldLink link;
      read_present<uint32_t>(params["world"], "world", {{"domain", &link.domain}}, errors);
      read_present<std::string>(params["world"], "world", {{"robot", &link.robot}}, errors);
      if (link.robot.empty()) errors.push_back("world.robot: required (the robot whose pose the camera rides on)");
      if (link.domain > 232) errors.push_back("world.domain: must be a DDS domain id, 0..232");
      if (params["pose"]) errors.push_back("pose: not allowed with world (the pose comes from the world state)");
      out.world = link;
    }
    if (present_map(params["camera"], "camera", {"width", "height", "hfov_deg", "mount_height"}, errors)) {
      read_present<unsigned>(params["camera"], "camera", {{"width", &camera.width}, {"height", &camera.height}},
                             errors);
      read_present<double>(params["camera"], "camera",
                           {{"hfov_deg", &camera.hfov_deg}, {"mount_height", &camera.mount_height}}, errors);
    }
    if (present_map(params["room"], "room", {"width", "depth", "wall_height"}, errors)) {
      read_present<double>(params["room"], "room",
                           {{"width", &world.room.width}, {"depth", &world.room.depth},
                            {"wall_height", &world.room.wall_height}},
                           errors);
    }
    if (const YAML::Node markers = params["markers"]) {
      if (!markers.IsSequence()) {
        errors.push_back("markers: must be a list");
      } else {
        world.markers.clear();
        for (size_t i = 0; i < markers.size(); ++i) {
          WallMarker m;
          const std::string where = "markers[" + std::to_string(i) + "]";
          if (present_map(markers[i], where, {"id", "x", "y", "z", "size"}, errors)) {
            read_present<double>(markers[i], where, {{"x", &m.x}, {"y", &m.y}, {"z", &m.z}, {"size", &m.size}},
                                 errors);
            read_present<int>(markers[i], where, {{"id", &m.id}}, errors);
            if (!markers[i]["id"] || !markers[i]["x"] || !markers[i]["y"]) {
              errors.push_back(where + ": id, x and y are required");
            }
          }
          world.markers.push_back(m);
        }
      }
    }
  }
  if (errors.empty()) {
    try {
      out.scene = std::make_shared<const Scene>(std::move(world), camera);
    } catch (const std::invalid_argument& e) {
      errors.push_back(e.what());
    }
  }
  if (!errors.empty()) {
    std::string message = "camera params: " + std::to_string(errors.size()) + " error(s):";
    for (const auto& e : errors) message += "\n  " + e;
    throw util::ConfigError(message);
  }
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
          return invalid_argument("encoding", encoding_name(encoding) +
                                                  " is not supported: the simulated camera delivers RAW_RGB8 or PNG");
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
  const auto now = std::chrono::duration_cast<std::chrono::nanoseconds>(
      std::chrono::system_clock::now().time_since_epoch()).count();
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
      throw util::ConfigError(std::string("camera params: world: ") + e.what());
    }
  } else {
    poses = std::make_shared<FixedPose>(parsed.pose);
  }
  return std::make_shared<CameraAgent>(std::move(parsed), std::move(poses));
}

}  // namespace urs::camera
