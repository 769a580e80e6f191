// The simulated camera's world model against ZBar: what geometry says a frame shows is what the
// recogniser reads from it.

#include "urs/camera/scene.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

#include "urs/camera/recognizer.hpp"

namespace urs::camera {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::set<std::string> decoded(const Scene& scene, const Pose& pose) {
  std::set<std::string> out;
  for (const auto& marker : find_markers(scene.render(pose))) out.insert(marker.content());
  return out;
}

std::string describe(const Pose& pose) {
  return "pose (" + std::to_string(pose.x) + ", " + std::to_string(pose.y) + ", " + std::to_string(pose.theta) + ")";
}

TEST(CameraScene, MarkerContentNamesIdAndPosition) {
  EXPECT_EQ((WallMarker{3, 3.0, 4.0, 1.0, 0.6}.content()), "urs:marker:3@3.0,4.0");
  EXPECT_EQ((WallMarker{12, 6.5, 0.25, 1.0, 0.6}.content()), "urs:marker:12@6.5,0.2");
}

TEST(CameraScene, FrameIs640x480Rgb) {
  Scene scene(default_lab(), CameraModel{});
  const RgbFrame frame = scene.render({3.25, 2.0, 0.0});
  EXPECT_EQ(frame.width, 640u);
  EXPECT_EQ(frame.height, 480u);
  EXPECT_EQ(frame.rgb.size(), 640u * 480u * 3u);
}

struct PoseCase {
  const char* what;
  Pose pose;
  std::set<std::string> expected;
};

TEST(CameraScene, FramesAtPosesDecodeToTheMarkersInView) {
  Scene scene(default_lab(), CameraModel{});
  const std::vector<PoseCase> cases = {
      {"room centre facing east", {3.25, 2.0, 0.0}, {"urs:marker:1@6.5,1.0", "urs:marker:2@6.5,3.0"}},
      {"facing north", {3.0, 2.0, kPi / 2}, {"urs:marker:3@3.0,4.0"}},
      {"close to the west wall", {1.0, 2.0, kPi}, {"urs:marker:4@0.0,2.0"}},
      {"facing south, small marker out of view", {2.0, 1.0, -kPi / 2}, {"urs:marker:5@2.0,0.0"}},
      {"small marker from close by", {5.0, 0.6, -kPi / 2}, {"urs:marker:6@5.0,0.0"}},
      {"small marker from too far", {5.0, 2.5, -kPi / 2}, {}},
      {"facing a bare corner", {1.0, 1.0, -3 * kPi / 4}, {}},
      {"east wall at a slant", {4.0, 2.0, 0.35}, {"urs:marker:2@6.5,3.0"}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(std::string(c.what) + " " + describe(c.pose));
    ASSERT_EQ(scene.contents(c.pose, Legibility::kBorderline), std::set<std::string>{})
        << "a marker is at the edge of legibility: the case would not test anything";
    EXPECT_EQ(scene.contents(c.pose, Legibility::kLegible), c.expected) << "world model";
    EXPECT_EQ(decoded(scene, c.pose), c.expected) << "recogniser";
  }
}

TEST(CameraScene, TooFarMarkerIsInViewButNotDecoded) {
  Scene scene(default_lab(), CameraModel{});
  const Pose pose{5.0, 2.5, -kPi / 2};
  for (const auto& view : scene.views(pose)) {
    if (view.marker->id != 6) continue;
    EXPECT_TRUE(view.in_image);
    EXPECT_LT(view.module_px, kIllegibleModulePx);
  }
  EXPECT_EQ(decoded(scene, pose), std::set<std::string>{});
}

// Every pose of a grid over the lab, eight headings each: the recogniser reads every marker the
// model calls legible, and nothing the model calls illegible.
TEST(CameraScene, RecogniserAgreesWithTheModelOverTheLab) {
  Scene scene(default_lab(), CameraModel{});
  int legible_seen = 0;
  for (double x = 0.6; x < 6.5; x += 1.3) {
    for (double y = 0.5; y < 4.0; y += 1.0) {
      for (int k = 0; k < 8; ++k) {
        const Pose pose{x, y, k * kPi / 4 - kPi};
        SCOPED_TRACE(describe(pose));
        const auto legible = scene.contents(pose, Legibility::kLegible);
        auto possible = scene.contents(pose, Legibility::kBorderline);
        possible.insert(legible.begin(), legible.end());
        const auto read = decoded(scene, pose);
        for (const auto& content : legible) EXPECT_EQ(read.count(content), 1u) << "missed " << content;
        for (const auto& content : read) EXPECT_EQ(possible.count(content), 1u) << "unexpected " << content;
        legible_seen += static_cast<int>(legible.size());
      }
    }
  }
  EXPECT_GT(legible_seen, 40) << "the grid should look at markers often";
}

TEST(CameraScene, CornersAreClockwiseFromTheSymbolsTopLeft) {
  Scene scene(default_lab(), CameraModel{});
  const Pose pose{3.25, 2.0, 0.0};
  const auto markers = find_markers(scene.render(pose));
  ASSERT_EQ(markers.size(), 2u);
  for (const auto& view : scene.views(pose)) {
    if (view.legibility != Legibility::kLegible) continue;
    SCOPED_TRACE(view.marker->content());
    const auto* found = &markers[0];
    if (found->content() != view.marker->content()) found = &markers[1];
    ASSERT_EQ(found->content(), view.marker->content());
    ASSERT_EQ(found->corners_size(), 4);
    const double tolerance = 2.5 * view.module_px;  // ZBar locates the symbol to about a module
    for (int i = 0; i < 4; ++i) {
      EXPECT_NEAR(found->corners(i).x(), view.corners[i].x, tolerance) << "corner " << i;
      EXPECT_NEAR(found->corners(i).y(), view.corners[i].y, tolerance) << "corner " << i;
      EXPECT_GE(found->corners(i).x(), found->bbox().x());
      EXPECT_LE(found->corners(i).x(), found->bbox().x() + found->bbox().width());
      EXPECT_GE(found->corners(i).y(), found->bbox().y());
      EXPECT_LE(found->corners(i).y(), found->bbox().y() + found->bbox().height());
    }
    EXPECT_FLOAT_EQ(found->confidence(), 1.0f);
  }
}

TEST(CameraScene, MarkersOffTheWallsAreRefused) {
  World world;
  world.markers = {{7, 3.0, 2.0, 1.0, 0.6}};
  try {
    Scene scene(world, CameraModel{});
    FAIL() << "accepted a marker in the middle of the room";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("marker 7"), std::string::npos) << e.what();
  }
  world.markers = {{8, 6.5, 0.1, 1.0, 0.6}};
  EXPECT_THROW(Scene(world, CameraModel{}), std::invalid_argument) << "plate overhanging the corner";
}

TEST(CameraScene, PosesOutsideTheRoomSeeNoMarkers) {
  Scene scene(default_lab(), CameraModel{});
  const Pose outside{8.0, 2.0, kPi};  // behind the east wall, looking at its back
  EXPECT_EQ(scene.contents(outside, Legibility::kLegible), std::set<std::string>{});
  EXPECT_EQ(decoded(scene, outside), std::set<std::string>{});
}

}  // namespace
}  // namespace urs::camera
