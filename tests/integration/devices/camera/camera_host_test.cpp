// The camera device as a space sees it: the agent made by its factory from YAML params, hosted by
// an AgentHost, called with serialized Planet requests.

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <future>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "ImageRecognition.pb.h"
#include "dds_domain.hpp"
#include "urs/agent/agent.hpp"
#include "urs/camera/camera_agent.hpp"
#include "urs/camera/image_codec.hpp"
#include "urs/world/world.hpp"

namespace urs::camera {
namespace {

using namespace std::chrono_literals;

class RecordingSink : public agent::EventSink {
 public:
  call::Reply publish(const std::string& topic, const google::protobuf::Message& event) override {
    std::lock_guard<std::mutex> lock(mutex_);
    URC::ImageRecognition_recognize_Reply markers;
    markers.CopyFrom(event);
    events_.emplace_back(topic, markers);
    arrived_.notify_all();
    return call::Reply::success({});
  }
  std::vector<std::pair<std::string, URC::ImageRecognition_recognize_Reply>> wait_for(size_t count) {
    std::unique_lock<std::mutex> lock(mutex_);
    arrived_.wait_for(lock, 10s, [&] { return events_.size() >= count; });
    return events_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::vector<std::pair<std::string, URC::ImageRecognition_recognize_Reply>> events_;
};

class CameraHost {
 public:
  explicit CameraHost(const std::string& params_yaml) : host_(2, sink_) {
    host_.add({"camera", make_camera_agent(YAML::Load(params_yaml)), {{"room", "lab"}}, 5000});
    host_.start();
  }

  call::Reply call(const std::string& operation, const google::protobuf::Message& request) {
    call::Request sent;
    sent.service = "camera";
    sent.operation = operation;
    sent.payload = request.SerializeAsString();
    auto promise = std::make_shared<std::promise<call::Reply>>();
    auto future = promise->get_future();
    host_.dispatch(std::move(sent),
                   call::Responder::from_callback([promise](call::Reply r) { promise->set_value(r); }));
    if (future.wait_for(10s) != std::future_status::ready)
      return call::Reply::error(call::Status::INTERNAL, "no answer");
    return future.get();
  }

  template <class Reply>
  Reply ok(const std::string& operation, const google::protobuf::Message& request) {
    const auto result = call(operation, request);
    EXPECT_TRUE(result.ok()) << operation << ": " << result.message;
    Reply reply;
    EXPECT_TRUE(reply.ParseFromString(result.payload));
    return reply;
  }

  void open() { ok<URC::ImageRecognition_openCamera_Reply>("openCamera", URC::ImageRecognition_openCamera_Request()); }

  URC::Image capture(URC::ImageEncoding encoding) {
    URC::ImageRecognition_captureImage_Request request;
    request.set_encoding(encoding);
    return ok<URC::ImageRecognition_captureImage_Reply>("captureImage", request).result();
  }

  std::set<std::string> recognize() {
    const auto reply =
        ok<URC::ImageRecognition_recognize_Reply>("recognize", URC::ImageRecognition_recognize_Request());
    std::set<std::string> out;
    for (const auto& marker : reply.result()) out.insert(marker.content());
    return out;
  }

  RecordingSink& events() { return sink_; }

 private:
  RecordingSink sink_;
  agent::AgentHost host_;
};

template <class Exception>
Exception raised(const call::Reply& result, const std::string& type) {
  EXPECT_EQ(result.status, call::Status::USER_EXCEPTION) << result.message;
  EXPECT_EQ(result.exception_type, type);
  Exception exception;
  EXPECT_TRUE(exception.ParseFromString(result.payload));
  return exception;
}

TEST(CameraDevice, EveryOperationButOpenIsNotReadyWhileClosed) {
  CameraHost camera("");
  URC::ImageRecognition_captureImage_Request capture;
  capture.set_encoding(URC::IMAGE_ENCODING_PNG);
  EXPECT_EQ(raised<URC::NotReady>(camera.call("captureImage", capture), "URC.NotReady").reason(), "camera not open");
  EXPECT_EQ(raised<URC::NotReady>(camera.call("getImageFormat", URC::ImageRecognition_getImageFormat_Request()),
                                  "URC.NotReady")
                .reason(),
            "camera not open");
  EXPECT_EQ(raised<URC::NotReady>(camera.call("recognize", URC::ImageRecognition_recognize_Request()), "URC.NotReady")
                .reason(),
            "camera not open");

  URC::ImageRecognition_openCamera_Request other;
  other.set_device(1);
  EXPECT_EQ(raised<URC::NotReady>(camera.call("openCamera", other), "URC.NotReady").reason(),
            "no camera 1: this simulated camera is device 0");

  camera.open();
  camera.open();  // opening an open camera is not an error
  EXPECT_TRUE(camera.call("recognize", URC::ImageRecognition_recognize_Request()).ok());
  camera.ok<URC::ImageRecognition_closeCamera_Reply>("closeCamera", URC::ImageRecognition_closeCamera_Request());
  EXPECT_EQ(camera.call("recognize", URC::ImageRecognition_recognize_Request()).exception_type, "URC.NotReady");
}

TEST(CameraDevice, FormatAndBothEncodingsCarryTheSameFrame) {
  CameraHost camera("pose: {x: 3.25, y: 2.0, theta: 0.0}");
  camera.open();
  const auto format = camera
                          .ok<URC::ImageRecognition_getImageFormat_Reply>(
                              "getImageFormat", URC::ImageRecognition_getImageFormat_Request())
                          .result();
  EXPECT_EQ(format.width(), 640u);
  EXPECT_EQ(format.height(), 480u);
  EXPECT_EQ(format.encoding(), URC::IMAGE_ENCODING_RAW_RGB8);

  const URC::Image raw = camera.capture(URC::IMAGE_ENCODING_RAW_RGB8);
  EXPECT_EQ(raw.format().encoding(), URC::IMAGE_ENCODING_RAW_RGB8);
  EXPECT_EQ(raw.format().width(), 640u);
  ASSERT_EQ(raw.data().size(), 640u * 480u * 3u);
  EXPECT_GT(raw.stamp().sec(), 1'600'000'000);
  EXPECT_LT(raw.stamp().nsec(), 1'000'000'000u);

  const URC::Image png = camera.capture(URC::IMAGE_ENCODING_PNG);
  EXPECT_EQ(png.format().encoding(), URC::IMAGE_ENCODING_PNG);
  const RgbFrame decoded = decode_png(png.data());
  EXPECT_EQ(decoded.width, 640u);
  EXPECT_EQ(decoded.height, 480u);
  EXPECT_EQ(std::string(decoded.rgb.begin(), decoded.rgb.end()), raw.data()) << "PNG differs from RAW";
  std::printf("[ figures  ] PNG frame %zu bytes (RAW %zu)\n", png.data().size(), raw.data().size());
}

TEST(CameraDevice, BadEncodingsAreInvalidArguments) {
  CameraHost camera("");
  camera.open();
  URC::ImageRecognition_captureImage_Request request;
  request.set_encoding(URC::IMAGE_ENCODING_JPEG);
  auto jpeg = raised<URC::InvalidArgument>(camera.call("captureImage", request), "URC.InvalidArgument");
  EXPECT_EQ(jpeg.parameter(), "encoding");
  EXPECT_EQ(jpeg.reason(), "JPEG is not supported: the simulated camera delivers RAW_RGB8 or PNG");
  request.set_encoding(static_cast<URC::ImageEncoding>(7));
  auto unknown = raised<URC::InvalidArgument>(camera.call("captureImage", request), "URC.InvalidArgument");
  EXPECT_EQ(unknown.parameter(), "encoding");
  EXPECT_EQ(unknown.reason(),
            "value 7 (not an ImageEncoding) is not supported: the simulated camera delivers RAW_RGB8 or PNG");
}

TEST(CameraDevice, RecognitionAtPosesReadsTheMarkersInViewAndPublishesThem) {
  struct Case {
    const char* pose;
    std::set<std::string> expected;
  };
  const std::vector<Case> cases = {
      {"{x: 3.25, y: 2.0, theta: 0.0}", {"urs:marker:1@6.5,1.0", "urs:marker:2@6.5,3.0"}},
      {"{x: 3.0, y: 2.0, theta: 1.5708}", {"urs:marker:3@3.0,4.0"}},
      {"{x: 1.0, y: 2.0, theta: 3.1416}", {"urs:marker:4@0.0,2.0"}},
      {"{x: 5.0, y: 0.6, theta: -1.5708}", {"urs:marker:6@5.0,0.0"}},
      {"{x: 5.0, y: 2.5, theta: -1.5708}", {}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.pose);
    CameraHost camera(std::string("event_prefix: lab/camera\npose: ") + c.pose);
    camera.open();
    EXPECT_EQ(camera.recognize(), c.expected);
    const auto events = camera.events().wait_for(1);
    ASSERT_EQ(events.size(), 1u);
    EXPECT_EQ(events[0].first, "lab/camera/markers");
    std::set<std::string> published;
    for (const auto& marker : events[0].second.result()) published.insert(marker.content());
    EXPECT_EQ(published, c.expected);
  }
}

TEST(CameraDevice, ScanningPublishesMarkersWhileOpen) {
  CameraHost camera("scan_hz: 10\npose: {x: 3.0, y: 2.0, theta: 1.5708}");
  camera.open();
  const auto events = camera.events().wait_for(2);
  ASSERT_GE(events.size(), 2u);
  for (const auto& [topic, markers] : events) {
    EXPECT_EQ(topic, "camera/markers");
    ASSERT_EQ(markers.result_size(), 1);
    EXPECT_EQ(markers.result(0).content(), "urs:marker:3@3.0,4.0");
  }
}

// The robot's pose arrives over DDS from another participant; the camera follows it.
TEST(CameraDevice, FollowsTheRobotPoseFromTheWorldState) {
  const urs::test::DdsDomains domains(1);  // away from other tests' domains
  const uint32_t domain = domains[0];
  const std::string robot = "cam-robot-" + std::to_string(getpid());
  urs::world::World simulator(domain, "simulator");
  CameraHost camera("world: {domain: " + std::to_string(domain) + ", robot: " + robot + "}");
  camera.open();
  EXPECT_EQ(raised<URC::NotReady>(camera.call("recognize", URC::ImageRecognition_recognize_Request()), "URC.NotReady")
                .reason(),
            "no robot pose known yet");

  // Recognises until the markers seen change to `expected`, or 10 s pass.
  auto seen_after_move = [&](double x, double y, double theta, const std::set<std::string>& expected) {
    urs::world::PoseSample sample;
    sample.robot = robot;
    sample.x = x, sample.y = y, sample.theta = theta;
    sample.stamp = std::chrono::system_clock::now();
    EXPECT_TRUE(simulator.publish(urs::world::Channel::ground_truth, sample));
    std::set<std::string> seen;
    for (auto until = std::chrono::steady_clock::now() + 10s; std::chrono::steady_clock::now() < until;) {
      const auto result = camera.call("recognize", URC::ImageRecognition_recognize_Request());
      if (result.ok()) {
        URC::ImageRecognition_recognize_Reply reply;
        reply.ParseFromString(result.payload);
        seen.clear();
        for (const auto& marker : reply.result()) seen.insert(marker.content());
        if (seen == expected) break;
      }
      std::this_thread::sleep_for(20ms);
    }
    return seen;
  };
  const std::set<std::string> east{"urs:marker:1@6.5,1.0", "urs:marker:2@6.5,3.0"};
  const std::set<std::string> north{"urs:marker:3@3.0,4.0"};
  EXPECT_EQ(seen_after_move(3.25, 2.0, 0.0, east), east);
  EXPECT_EQ(seen_after_move(3.0, 2.0, 1.5708, north), north);
}

TEST(CameraDevice, CaptureAndRecognitionTimesArePrinted) {
  CameraHost camera("");
  camera.open();
  constexpr int kRounds = 10;
  auto timed = [&](const std::string& operation, const google::protobuf::Message& request) {
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < kRounds; ++i) EXPECT_TRUE(camera.call(operation, request).ok());
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() / kRounds;
  };
  URC::ImageRecognition_captureImage_Request raw, png;
  raw.set_encoding(URC::IMAGE_ENCODING_RAW_RGB8);
  png.set_encoding(URC::IMAGE_ENCODING_PNG);
  const double raw_ms = timed("captureImage", raw);
  const double png_ms = timed("captureImage", png);
  const double recognize_ms = timed("recognize", URC::ImageRecognition_recognize_Request());
  std::printf(
      "[ figures  ] 640x480 through AgentHost, mean of %d: captureImage RAW_RGB8 %.1f ms, PNG %.1f ms, "
      "recognize (capture + ZBar) %.1f ms\n",
      kRounds, raw_ms, png_ms, recognize_ms);
}

}  // namespace
}  // namespace urs::camera
