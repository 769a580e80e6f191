#pragma once
// The simulated camera's world: a rectangular room whose walls carry QR markers, seen through a
// pinhole camera mounted on the robot. The same model renders frames and predicts which markers a
// frame should show, so tests can compare what the recogniser reads with what geometry expects.
//
// Frames: the room's floor plane holds x (east) and y (north) in metres, as in URC; z is up. The
// room spans [0, width] x [0, depth]; walls rise from z = 0 to wall_height.

#include <array>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace urs::camera {

struct Pose {
  double x = 0;      // m
  double y = 0;      // m
  double theta = 0;  // rad, counter-clockwise from +x: the direction the camera looks along
};

// A square white plate on a wall holding one QR symbol and its 4-module quiet zone.
struct WallMarker {
  int id = 0;
  double x = 0;       // m, centre of the plate; must lie on a wall
  double y = 0;       // m
  double z = 1.0;     // m, height of the plate's centre above the floor
  double size = 0.6;  // m, side of the plate

  // "urs:marker:<id>@<x>,<y>" with x and y rounded to decimetres.
  std::string content() const;
};

struct Room {
  double width = 6.5;        // m, along x
  double depth = 4.0;        // m, along y
  double wall_height = 2.5;  // m
};

struct World {
  Room room;
  std::vector<WallMarker> markers;
};

// The 6.5 x 4 m lab of the square path, with six markers: two on the east wall, one on each of
// the other walls, and a small one on the south wall that is legible only from close by.
World default_lab();

struct CameraModel {
  unsigned width = 640;       // pixels
  unsigned height = 480;      // pixels
  double hfov_deg = 60;       // horizontal field of view
  double mount_height = 1.0;  // m, optical centre above the floor; the optical axis is horizontal

  double focal_px() const;  // focal length in pixels (square pixels)
};

struct PixelXY {
  double x = 0;  // pixels, to the right
  double y = 0;  // pixels, downwards
};

// How readable a marker is in a frame, judged from geometry alone. Between the two thresholds
// below ZBar reads some frames and misses others (measured over poses of the whole lab; see
// docs/devices.md), so predictions there are left open.
enum class Legibility {
  kLegible,     // whole QR symbol in the image, modules at least kLegibleModulePx
  kBorderline,  // anything between
  kIllegible,   // behind the camera, outside the image, or modules under kIllegibleModulePx
};
inline constexpr double kLegibleModulePx = 2.5;
inline constexpr double kIllegibleModulePx = 1.5;

// Where a marker appears from a pose.
struct MarkerView {
  const WallMarker* marker = nullptr;
  bool facing = false;               // seen from inside the room, the whole symbol in front of the camera
  std::array<PixelXY, 4> corners{};  // of the QR symbol (quiet zone excluded), clockwise from its top-left
  bool in_image = false;             // the whole QR symbol projects inside the image
  bool overlaps_image = false;       // some of the QR symbol's bounding box projects inside the image
  double module_px = 0;              // smallest apparent side of one QR module, pixels
  Legibility legibility = Legibility::kIllegible;
};

struct RgbFrame {
  unsigned width = 0;
  unsigned height = 0;
  std::vector<std::uint8_t> rgb;  // width*height*3, row-major, R G B per pixel
};

class Scene {
 public:
  // Throws std::invalid_argument naming the first marker that is off the walls, too big for its
  // wall, or whose content cannot be encoded, and for a room or camera that makes no sense.
  Scene(World world, CameraModel camera);

  const World& world() const { return world_; }
  const CameraModel& camera() const { return camera_; }

  RgbFrame render(const Pose& pose) const;

  std::vector<MarkerView> views(const Pose& pose) const;  // one per marker, in world order

  // Contents of the markers whose view from `pose` has the given legibility.
  std::set<std::string> contents(const Pose& pose, Legibility legibility) const;

 private:
  enum class Wall { kWest, kEast, kSouth, kNorth };
  struct Symbol {  // a marker's QR modules and where they hang
    Wall wall = Wall::kWest;
    double right_x = 0;  // unit vector along the wall, to the right of a viewer facing it
    double right_y = 0;
    int modules = 0;         // QR modules per side, quiet zone excluded
    std::vector<bool> dark;  // modules*modules, row-major from the top-left
  };
  struct Ray {                    // the horizontal ray of one image column
    double cos_offset = 1;        // cosine of the angle between the ray and the optical axis
    double distance = 0;          // m, along the ray to the wall
    double hit_x = 0, hit_y = 0;  // m, where it meets the wall
    Wall wall = Wall::kWest;
  };
  bool inside(const Pose& pose) const;  // strictly inside the room: walls are seen from inside only
  Ray cast(const Pose& pose, double column) const;
  // R, G, B (0..255) of the point seen along `ray` at image row `row` (continuous pixel
  // coordinate); `on_plate` tells whether that point lies on a marker plate.
  std::array<double, 3> shade(const Ray& ray, double row, bool& on_plate) const;

  World world_;
  CameraModel camera_;
  std::vector<Symbol> symbols_;
};

}  // namespace urs::camera
