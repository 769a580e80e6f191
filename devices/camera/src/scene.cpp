#include "urs/camera/scene.hpp"

#include <qrencode.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>

namespace urs::camera {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kQuietModules = 4;   // QR quiet zone, modules on each side
constexpr double kOnWall = 1e-6;   // m, how far off a wall plane a marker may be
constexpr double kNearest = 0.05;  // m, points closer to the camera plane are not drawn

// Surface colours, R G B.
constexpr std::array<double, 3> kFloor{120, 104, 88};
constexpr std::array<double, 3> kCeiling{236, 236, 230};
constexpr std::array<double, 3> kPlate{250, 250, 250};
constexpr std::array<double, 3> kModule{16, 16, 16};

std::array<double, 3> scaled(const std::array<double, 3>& colour, double factor) {
  return {colour[0] * factor, colour[1] * factor, colour[2] * factor};
}

// Light falls off slowly with distance so that walls, floor and corners stay distinguishable.
double dimming(double distance) { return std::clamp(1.0 - 0.035 * distance, 0.6, 1.0); }

}  // namespace

std::string WallMarker::content() const {
  char text[96];
  std::snprintf(text, sizeof text, "urs:marker:%d@%.1f,%.1f", id, x, y);
  return text;
}

World default_lab() {
  World world;
  world.markers = {
      {1, 6.5, 1.0, 1.0, 0.6}, {2, 6.5, 3.0, 1.0, 0.6}, {3, 3.0, 4.0, 1.0, 0.6},
      {4, 0.0, 2.0, 1.0, 0.6}, {5, 2.0, 0.0, 1.0, 0.6}, {6, 5.0, 0.0, 1.0, 0.15},
  };
  return world;
}

double CameraModel::focal_px() const { return (width / 2.0) / std::tan(hfov_deg * kPi / 360.0); }

Scene::Scene(World world, CameraModel camera) : world_(std::move(world)), camera_(camera) {
  const Room& room = world_.room;
  if (!(room.width > 0 && room.depth > 0 && room.wall_height > 0)) {
    throw std::invalid_argument("room: width, depth and wall_height must be positive");
  }
  if (camera_.width == 0 || camera_.height == 0) throw std::invalid_argument("camera: empty image size");
  if (!(camera_.hfov_deg > 0 && camera_.hfov_deg < 180)) {
    throw std::invalid_argument("camera: hfov_deg must be in (0, 180)");
  }
  for (const WallMarker& m : world_.markers) {
    const std::string name = "marker " + std::to_string(m.id);
    if (!(m.size > 0)) throw std::invalid_argument(name + ": size must be positive");
    Symbol symbol;
    double along = 0, wall_length = 0;
    if (std::abs(m.x) < kOnWall) {
      symbol = {Wall::kWest, 0, 1, 0, {}};  // a viewer facing the west wall looks along -x
      along = m.y, wall_length = room.depth;
    } else if (std::abs(m.x - room.width) < kOnWall) {
      symbol = {Wall::kEast, 0, -1, 0, {}};
      along = m.y, wall_length = room.depth;
    } else if (std::abs(m.y) < kOnWall) {
      symbol = {Wall::kSouth, -1, 0, 0, {}};
      along = m.x, wall_length = room.width;
    } else if (std::abs(m.y - room.depth) < kOnWall) {
      symbol = {Wall::kNorth, 1, 0, 0, {}};
      along = m.x, wall_length = room.width;
    } else {
      throw std::invalid_argument(name + ": (" + std::to_string(m.x) + ", " + std::to_string(m.y) +
                                  ") is not on a wall of the room");
    }
    const double half = m.size / 2;
    if (along - half < 0 || along + half > wall_length || m.z - half < 0 || m.z + half > room.wall_height) {
      throw std::invalid_argument(name + ": the plate does not fit on its wall");
    }
    std::unique_ptr<QRcode, void (*)(QRcode*)> code(
        QRcode_encodeString(m.content().c_str(), 0, QR_ECLEVEL_M, QR_MODE_8, 1), QRcode_free);
    if (!code) throw std::invalid_argument(name + ": content cannot be encoded as a QR symbol");
    symbol.modules = code->width;
    symbol.dark.resize(static_cast<size_t>(code->width) * code->width);
    for (size_t i = 0; i < symbol.dark.size(); ++i) symbol.dark[i] = (code->data[i] & 1) != 0;
    symbols_.push_back(std::move(symbol));
  }
}

bool Scene::inside(const Pose& pose) const {
  return pose.x > 0 && pose.x < world_.room.width && pose.y > 0 && pose.y < world_.room.depth;
}

Scene::Ray Scene::cast(const Pose& pose, double column) const {
  const double offset = std::atan((camera_.width / 2.0 - column) / camera_.focal_px());  // left is positive
  const double dx = std::cos(pose.theta + offset), dy = std::sin(pose.theta + offset);
  Ray ray;
  ray.cos_offset = std::cos(offset);
  ray.distance = std::numeric_limits<double>::infinity();
  if (!inside(pose)) return ray;
  auto consider = [&](double t, Wall wall) {
    if (t > 0 && t < ray.distance) ray.distance = t, ray.wall = wall;
  };
  if (dx > 0) consider((world_.room.width - pose.x) / dx, Wall::kEast);
  if (dx < 0) consider(-pose.x / dx, Wall::kWest);
  if (dy > 0) consider((world_.room.depth - pose.y) / dy, Wall::kNorth);
  if (dy < 0) consider(-pose.y / dy, Wall::kSouth);
  ray.hit_x = pose.x + dx * ray.distance;
  ray.hit_y = pose.y + dy * ray.distance;
  return ray;
}

std::array<double, 3> Scene::shade(const Ray& ray, double row, bool& on_plate) const {
  on_plate = false;
  const double f = camera_.focal_px();
  const double below_axis = row - camera_.height / 2.0;  // pixels
  const double depth = ray.distance * ray.cos_offset;    // m, along the optical axis
  const double height = std::isinf(depth) ? (below_axis > 0 ? -1.0 : std::numeric_limits<double>::infinity())
                                          : camera_.mount_height - below_axis * depth / f;
  if (height < 0) {
    const double floor_distance = camera_.mount_height * f / below_axis / ray.cos_offset;
    return scaled(kFloor, dimming(floor_distance));
  }
  if (height > world_.room.wall_height) return kCeiling;
  for (size_t i = 0; i < symbols_.size(); ++i) {
    const Symbol& symbol = symbols_[i];
    if (symbol.wall != ray.wall) continue;
    const WallMarker& m = world_.markers[i];
    const double a = (ray.hit_x - m.x) * symbol.right_x + (ray.hit_y - m.y) * symbol.right_y + m.size / 2;
    const double b = m.z + m.size / 2 - height;
    if (a < 0 || a >= m.size || b < 0 || b >= m.size) continue;
    on_plate = true;
    const int across = symbol.modules + 2 * kQuietModules;
    const int col = static_cast<int>(a / m.size * across) - kQuietModules;
    const int line = static_cast<int>(b / m.size * across) - kQuietModules;
    const bool dark = col >= 0 && col < symbol.modules && line >= 0 && line < symbol.modules &&
                      symbol.dark[static_cast<size_t>(line) * symbol.modules + col];
    return scaled(dark ? kModule : kPlate, dimming(ray.distance));
  }
  static constexpr std::array<std::array<double, 3>, 4> kWalls{
      {{196, 186, 160}, {178, 192, 200}, {200, 180, 176}, {184, 196, 172}}};  // west, east, south, north
  return scaled(kWalls[static_cast<size_t>(ray.wall)], dimming(ray.distance));
}

RgbFrame Scene::render(const Pose& pose) const {
  RgbFrame frame{camera_.width, camera_.height, {}};
  frame.rgb.resize(static_cast<size_t>(frame.width) * frame.height * 3);
  // Pixels on a marker plate are averaged over 3x3 samples: without it, modules a few pixels wide
  // alias into uneven bars, which no real lens produces.
  constexpr double kSub[3] = {1.0 / 6, 0.5, 5.0 / 6};
  std::array<Ray, 3> rays;
  for (unsigned u = 0; u < frame.width; ++u) {
    for (int s = 0; s < 3; ++s) rays[s] = cast(pose, u + kSub[s]);
    for (unsigned v = 0; v < frame.height; ++v) {
      bool on_plate = false;
      std::array<double, 3> colour = shade(rays[1], v + 0.5, on_plate);
      if (on_plate) {
        colour = {0, 0, 0};
        for (const Ray& ray : rays) {
          for (double dv : kSub) {
            bool ignored = false;
            const auto sample = shade(ray, v + dv, ignored);
            for (int c = 0; c < 3; ++c) colour[c] += sample[c] / 9;
          }
        }
      }
      std::uint8_t* pixel = &frame.rgb[(static_cast<size_t>(v) * frame.width + u) * 3];
      for (int c = 0; c < 3; ++c) pixel[c] = static_cast<std::uint8_t>(std::lround(std::clamp(colour[c], 0.0, 255.0)));
    }
  }
  return frame;
}

std::vector<MarkerView> Scene::views(const Pose& pose) const {
  const double f = camera_.focal_px();
  const double cos_t = std::cos(pose.theta), sin_t = std::sin(pose.theta);
  std::vector<MarkerView> out;
  for (size_t i = 0; i < symbols_.size(); ++i) {
    const Symbol& symbol = symbols_[i];
    const WallMarker& m = world_.markers[i];
    MarkerView view;
    view.marker = &m;
    bool in_front = inside(pose);
    // (a, b): metres from the plate's top-left corner, to the right and downwards.
    auto project = [&](double a, double b) {
      const double wx = m.x + symbol.right_x * (a - m.size / 2) - pose.x;
      const double wy = m.y + symbol.right_y * (a - m.size / 2) - pose.y;
      const double forward = wx * cos_t + wy * sin_t;
      const double left = -wx * sin_t + wy * cos_t;
      const double up = m.z + m.size / 2 - b - camera_.mount_height;
      if (forward < kNearest) in_front = false;
      PixelXY p{camera_.width / 2.0 - f * left / forward, camera_.height / 2.0 - f * up / forward};
      return p;
    };
    const double q = m.size * kQuietModules / (symbol.modules + 2 * kQuietModules);
    view.corners = {project(q, q), project(m.size - q, q), project(m.size - q, m.size - q), project(q, m.size - q)};
    double left = camera_.width, right = 0, top = camera_.height, bottom = 0;
    for (const PixelXY& p : view.corners) {
      left = std::min(left, p.x), right = std::max(right, p.x);
      top = std::min(top, p.y), bottom = std::max(bottom, p.y);
    }
    view.facing = in_front;
    view.in_image = in_front && left >= 0 && right <= camera_.width && top >= 0 && bottom <= camera_.height;
    view.overlaps_image = in_front && left < camera_.width && right > 0 && top < camera_.height && bottom > 0;
    if (in_front) {
      auto length = [](const PixelXY& p, const PixelXY& r) { return std::hypot(p.x - r.x, p.y - r.y); };
      const auto& c = view.corners;
      view.module_px =
          std::min({length(c[0], c[1]), length(c[3], c[2]), length(c[0], c[3]), length(c[1], c[2])}) / symbol.modules;
    }
    if (view.in_image && view.module_px >= kLegibleModulePx) {
      view.legibility = Legibility::kLegible;
    } else if (view.overlaps_image && view.module_px >= kIllegibleModulePx) {
      view.legibility = Legibility::kBorderline;
    }
    out.push_back(view);
  }
  return out;
}

std::set<std::string> Scene::contents(const Pose& pose, Legibility legibility) const {
  std::set<std::string> out;
  for (const MarkerView& view : views(pose)) {
    if (view.legibility == legibility) out.insert(view.marker->content());
  }
  return out;
}

}  // namespace urs::camera
