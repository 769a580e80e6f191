// The camera agent on its own: parameters, and the pose it renders from (a mocked PoseSource).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "urs/camera/camera_agent.hpp"
#include "urs/util/cli.hpp"

namespace urs::camera {
namespace {

using ::testing::_;
using ::testing::HasSubstr;
using ::testing::Return;

constexpr double kPi = 3.14159265358979323846;

class MockPoseSource : public PoseSource {
 public:
  MOCK_METHOD(std::optional<Pose>, current, (), (override));
};

class MockEventSink : public agent::EventSink {
 public:
  MOCK_METHOD(call::Reply, publish, (const std::string&, const google::protobuf::Message&), (override));
};

std::string config_error(const std::string& yaml) {
  try {
    parse_camera_params(YAML::Load(yaml));
  } catch (const util::ConfigError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(CameraParams, DefaultsAreTheLabSeenFromItsCentre) {
  const CameraParams params = parse_camera_params(YAML::Node());
  ASSERT_TRUE(params.scene);
  EXPECT_EQ(params.scene->world().markers.size(), 6u);
  EXPECT_EQ(params.scene->camera().width, 640u);
  EXPECT_EQ(params.scene->camera().height, 480u);
  EXPECT_DOUBLE_EQ(params.pose.x, 3.25);
  EXPECT_EQ(params.event_prefix, "camera");
  EXPECT_EQ(params.device, 0u);
}

TEST(CameraParams, EverySettingIsRead) {
  const CameraParams params = parse_camera_params(YAML::Load(R"(
    device: 2
    event_prefix: lab/cam
    scan_hz: 2
    pose: {x: 1, y: 1.5, theta: 3.1}
    camera: {width: 320, height: 240, hfov_deg: 50, mount_height: 0.8}
    room: {width: 5, depth: 3, wall_height: 2}
    markers: [{id: 9, x: 5, y: 1.5, z: 0.9, size: 0.5}]
  )"));
  EXPECT_EQ(params.device, 2u);
  EXPECT_EQ(params.event_prefix, "lab/cam");
  EXPECT_DOUBLE_EQ(params.scan_hz, 2);
  EXPECT_DOUBLE_EQ(params.pose.theta, 3.1);
  EXPECT_EQ(params.scene->camera().width, 320u);
  EXPECT_DOUBLE_EQ(params.scene->camera().hfov_deg, 50);
  EXPECT_DOUBLE_EQ(params.scene->world().room.depth, 3);
  ASSERT_EQ(params.scene->world().markers.size(), 1u);
  EXPECT_EQ(params.scene->world().markers[0].content(), "urs:marker:9@5.0,1.5");
}

TEST(CameraParams, EveryMistakeIsNamedByItsKey) {
  const std::string error = config_error(R"(
    lens: wide
    scan_hz: 100
    pose: {x: east}
    camera: {width: -3, zoom: 2}
    markers: [{x: 1, y: 0}]
  )");
  EXPECT_THAT(error, HasSubstr("camera params: 6 error(s):"));
  EXPECT_THAT(error, HasSubstr("lens: unknown key"));
  EXPECT_THAT(error, HasSubstr("scan_hz: must be in 0..30"));
  EXPECT_THAT(error, HasSubstr("pose.x: 'east' is not a valid value"));
  EXPECT_THAT(error, HasSubstr("camera.width: '-3' is not a valid value"));
  EXPECT_THAT(error, HasSubstr("camera.zoom: unknown key"));
  EXPECT_THAT(error, HasSubstr("markers[0]: id, x and y are required"));
  EXPECT_THAT(config_error("markers: [{id: 4, x: 2, y: 2}]"), HasSubstr("marker 4: (2.000000, 2.000000) is not on a wall"));
  const std::string world = config_error("world: {domain: 300}\npose: {x: 1}");
  EXPECT_THAT(world, HasSubstr("world.robot: required"));
  EXPECT_THAT(world, HasSubstr("world.domain: must be a DDS domain id, 0..232"));
  EXPECT_THAT(world, HasSubstr("pose: not allowed with world"));
  EXPECT_THAT(config_error("room: {width: 0}"), HasSubstr("room: width, depth and wall_height must be positive"));
}

agent::Outcome invoke(agent::ServiceAgent& agent, const std::string& operation, const google::protobuf::Message& request,
                      google::protobuf::Message& reply, agent::EventSink& events) {
  const auto* method = agent.interface().FindMethodByName(operation);
  agent::CallContext ctx{"camera", {"", "tester", ""}, std::chrono::steady_clock::now() + std::chrono::seconds(10), &events};
  return agent.invoke(*method, request, reply, ctx);
}

std::set<std::string> contents(const URC::ImageRecognition_recognize_Reply& reply) {
  std::set<std::string> out;
  for (const auto& marker : reply.result()) out.insert(marker.content());
  return out;
}

TEST(CameraAgent, RendersFromThePoseSourcesCurrentPose) {
  auto poses = std::make_shared<MockPoseSource>();
  MockEventSink events;
  EXPECT_CALL(*poses, current())
      .WillOnce(Return(std::nullopt))
      .WillOnce(Return(Pose{3.25, 2.0, 0.0}))
      .WillOnce(Return(Pose{3.0, 2.0, kPi / 2}));
  EXPECT_CALL(events, publish("camera/markers", _)).Times(2).WillRepeatedly(Return(call::Reply::success({})));
  CameraAgent agent(parse_camera_params(YAML::Node()), poses);

  URC::ImageRecognition_openCamera_Reply opened;
  ASSERT_TRUE(invoke(agent, "openCamera", URC::ImageRecognition_openCamera_Request(), opened, events).status ==
              call::Status::OK);
  URC::ImageRecognition_recognize_Reply reply;
  const auto no_pose = invoke(agent, "recognize", URC::ImageRecognition_recognize_Request(), reply, events);
  ASSERT_EQ(no_pose.status, call::Status::USER_EXCEPTION);
  EXPECT_EQ(no_pose.message, "NotReady: no robot pose known yet");

  ASSERT_EQ(invoke(agent, "recognize", URC::ImageRecognition_recognize_Request(), reply, events).status, call::Status::OK);
  EXPECT_EQ(contents(reply), (std::set<std::string>{"urs:marker:1@6.5,1.0", "urs:marker:2@6.5,3.0"}));
  reply.Clear();
  ASSERT_EQ(invoke(agent, "recognize", URC::ImageRecognition_recognize_Request(), reply, events).status, call::Status::OK);
  EXPECT_EQ(contents(reply), std::set<std::string>{"urs:marker:3@3.0,4.0"});
}

TEST(CameraAgent, AClosedCameraDoesNotAskForThePose) {
  auto poses = std::make_shared<MockPoseSource>();
  MockEventSink events;
  EXPECT_CALL(*poses, current()).Times(0);
  EXPECT_CALL(events, publish(_, _)).Times(0);
  CameraAgent agent(parse_camera_params(YAML::Node()), poses);
  URC::ImageRecognition_recognize_Reply reply;
  const auto closed = invoke(agent, "recognize", URC::ImageRecognition_recognize_Request(), reply, events);
  ASSERT_EQ(closed.status, call::Status::USER_EXCEPTION);
  ASSERT_TRUE(closed.exception);
  EXPECT_EQ(closed.exception->GetTypeName(), "URC.NotReady");
  EXPECT_EQ(static_cast<const URC::NotReady&>(*closed.exception).reason(), "camera not open");
}

}  // namespace
}  // namespace urs::camera
