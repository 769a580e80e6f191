// The camera agent on its own: the pose it renders from (a mocked PoseSource). Its params:
// tests/unit/devices/common/params_test.cpp.

#include "urs/camera/camera_agent.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

namespace urs::camera {
namespace {

using ::testing::_;
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

agent::Outcome invoke(agent::ServiceAgent& agent, const std::string& operation,
                      const google::protobuf::Message& request, google::protobuf::Message& reply,
                      agent::EventSink& events) {
  const auto* method = agent.interface().FindMethodByName(operation);
  agent::CallContext ctx{
      "camera", {"", "tester", ""}, std::chrono::steady_clock::now() + std::chrono::seconds(10), &events};
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

  ASSERT_EQ(invoke(agent, "recognize", URC::ImageRecognition_recognize_Request(), reply, events).status,
            call::Status::OK);
  EXPECT_EQ(contents(reply), (std::set<std::string>{"urs:marker:1@6.5,1.0", "urs:marker:2@6.5,3.0"}));
  reply.Clear();
  ASSERT_EQ(invoke(agent, "recognize", URC::ImageRecognition_recognize_Request(), reply, events).status,
            call::Status::OK);
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
