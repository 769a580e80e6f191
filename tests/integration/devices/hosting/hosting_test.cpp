// Every device runs from configuration alone in both hostings, and a client sees the same
// behaviour through each: as service agents of urs-sam (called with the `urs` CLI through
// urs-camus-server) and as RT-Components of urs-rtc-manager (called through omniORB stubs on
// their provider ports, found in a real omniNames). The scenario chains devices: the TTS speaks a
// robot command, the voice recognition hears it; the robot drives with the localizer in the
// loop; the camera reads the markers in front of it.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>

#include "ImageRecognition.hh"
#include "Localization.hh"
#include "Navigation.hh"
#include "TextToSpeech.hh"
#include "VoiceRecognition.hh"
#include "dds_domain.hpp"
#include "rt_space.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;

// A DDS domain of its own for the process, so that tests running at the same time do not see each
// other's robot.
int test_domain() {
  static const urs::test::DdsDomains domains(1);
  return static_cast<int>(domains[0]);
}

std::string device_params(const std::string& device) {
  const std::string domain = std::to_string(test_domain());
  if (device == "robot") return "{name: robot1, time_scale: 10, domain: " + domain + "}";
  if (device == "localizer") return "{robot: robot1, time_scale: 10, domain: " + domain + "}";
  if (device == "camera") return "{pose: {x: 3.25, y: 2.0, theta: 0.0}}";
  return "{}";
}

// What a client observed; both hostings must observe the same.
struct Observed {
  std::string heard;           // the voice device's text for the TTS's audio
  double position_error = -1;  // metres between the robot's reported position and its target
  std::string markers;         // sorted marker contents the camera read
};

// Every string value of "key" in a JSON text (no escapes in the values these tests read). Plain
// search: std::regex recurses per character and overflows the stack on a base64 WAV.
std::vector<std::string> json_strings(const std::string& json, const std::string& key) {
  std::vector<std::string> values;
  const std::string opening = "\"" + key + "\":\"";
  for (auto at = json.find(opening); at != std::string::npos; at = json.find(opening, at)) {
    at += opening.size();
    values.push_back(json.substr(at, json.find('"', at) - at));
  }
  return values;
}

std::string json_string(const std::string& json, const std::string& key) {
  const auto values = json_strings(json, key);
  return values.empty() ? std::string() : values.front();
}

double json_number(const std::string& json, const std::string& key) {
  const auto at = json.find("\"" + key + "\":");
  return at == std::string::npos ? NAN : std::strtod(json.c_str() + at + key.size() + 3, nullptr);
}

std::string sorted_contents(std::vector<std::string> contents) {
  std::sort(contents.begin(), contents.end());
  std::string out;
  for (const auto& c : contents) out += c + ";";
  return out;
}

constexpr double kTargetX = 2.0;
constexpr double kTargetY = 1.5;
constexpr const char* kCommand = "go forward";
// What the camera at the room's centre facing east (+x) reads: the two markers on the east wall.
constexpr const char* kMarkersFacingEast = "urs:marker:1@6.5,1.0;urs:marker:2@6.5,3.0;";

// ---- hosted by urs-sam ----

class SamHosting : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = make_temp_dir("hosting-sa");
    server_ =
        std::make_unique<Process>(std::vector<std::string>{URS_SERVER_BIN, "--space", "lab", "--listen", "127.0.0.1:0",
                                                           "--data-dir", dir_ + "/data", "--port-file", dir_ + "/port"},
                                  dir_ + "/server.log");
    ASSERT_TRUE(wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, 10s)) << server_->log();
    address_ = "127.0.0.1:" + read_text(dir_ + "/port");
    std::string config = "agents:\n";
    for (const char* device : {"robot", "localizer", "tts", "voice", "camera"}) {
      config += std::string("  - {name: ") + device + ", type: " + device +
                ", deadline_ms: 20000, params: " + device_params(device) + "}\n";
    }
    std::ofstream(dir_ + "/sam.yaml") << config;
    sam_ = std::make_unique<Process>(
        std::vector<std::string>{URS_SAM_BIN, "--space", "lab", "--server", address_, "--config", dir_ + "/sam.yaml"},
        dir_ + "/sam.log");
    ASSERT_TRUE(wait_until(
        [&] {
          return urs({"ls", "camera"}).out.find("camera ") != std::string::npos;
        },
        20s))
        << sam_->log();
  }
  void TearDown() override {
    if (HasFailure()) std::cerr << "---- sam log\n" << sam_->log() << "---- server log\n" << server_->log();
    sam_.reset();
    server_.reset();
    std::filesystem::remove_all(dir_);
  }
  CommandResult urs(std::vector<std::string> args) {
    args.insert(args.begin(), {URS_CLI_BIN, "--server", address_});
    return run_command(args, 60s);
  }
  CommandResult call(const std::string& service, const std::string& op, const std::string& json = "{}") {
    CommandResult r = urs({"call", service, op, json, "--deadline-ms", "20000"});
    EXPECT_EQ(r.exit_code, 0) << service << "." << op << ": " << r.err;
    return r;
  }

  std::string dir_, address_;
  std::unique_ptr<Process> server_, sam_;
};

TEST_F(SamHosting, EveryDeviceAnswersAsAServiceAgent) {
  Observed seen;
  // Speech: the TTS's WAV (base64 in the JSON reply) goes straight to the voice device.
  const std::string spoken = call("tts", "speak", std::string("{\"text\":\"") + kCommand + "\"}").out;
  const std::string wav = json_string(spoken, "wav");
  ASSERT_FALSE(wav.empty()) << spoken.substr(0, 200);
  const std::string heard = call("voice", "playBytes", "{\"wave\":\"" + wav + "\"}").out;
  seen.heard = json_string(heard, "text");
  EXPECT_EQ(seen.heard, kCommand) << heard;

  // Robot with the localizer in the loop.
  ASSERT_TRUE(wait_until([&] { return urs({"call", "localizer", "getPose"}).exit_code == 0; }, 20s));
  call("robot", "setSpeed", "{\"speed\":800}");
  EXPECT_NE(call("robot", "_get_speed").out.find("800"), std::string::npos);
  call("robot", "moveTo", "{\"x\":" + std::to_string(kTargetX) + ",\"y\":" + std::to_string(kTargetY) + "}");
  ASSERT_TRUE(wait_until([&] { return call("robot", "_get_state").out.find("ARRIVED") != std::string::npos; }, 60s));
  const std::string where = call("robot", "getPosition").out;
  seen.position_error = std::hypot(json_number(where, "x") - kTargetX, json_number(where, "y") - kTargetY);
  EXPECT_LT(seen.position_error, 0.05) << where;
  const CommandResult refused = urs({"call", "robot", "setSpeed", "{\"speed\":5000}"});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.err.find("URC.InvalidArgument"), std::string::npos) << refused.err;

  // Camera.
  EXPECT_EQ(urs({"call", "camera", "recognize"}).exit_code, 1);  // NotReady: not open
  call("camera", "openCamera", "{\"device\":0}");
  const std::string markers = call("camera", "recognize").out;
  const std::vector<std::string> contents = json_strings(markers, "content");
  EXPECT_FALSE(contents.empty()) << markers;
  seen.markers = sorted_contents(contents);
  EXPECT_EQ(seen.markers, kMarkersFacingEast);
  std::printf("SA hosting: heard '%s', robot %.3f m from its target, markers %s\n", seen.heard.c_str(),
              seen.position_error, seen.markers.c_str());
}

// ---- hosted by urs-rtc-manager ----

class RtcHosting : public RtSpaceTest {
 protected:
  // A device component's provider, narrowed to its IDL interface.
  template <typename T>
  typename T::_var_type provider(const std::string& component, const std::string& port, const std::string& type) {
    CORBA::Object_var object = provided_object("labhost.host_cxt/" + component + ".rtc", port, type, port);
    return T::_narrow(object);
  }
};

TEST_F(RtcHosting, EveryDeviceAnswersAsAnRtComponent) {
  std::string config = "components:\n";
  const std::pair<const char*, const char*> components[] = {{"Robot", "robot"},
                                                            {"Localizer", "localizer"},
                                                            {"TextToSpeech", "tts"},
                                                            {"VoiceRecognition", "voice"},
                                                            {"Camera", "camera"}};
  for (const auto& [type, device] : components) {
    config += std::string("  - {type: ") + type + ", config: {params: " + device_params(device) + "}}\n";
  }
  const std::string bound = start_manager("devices", "labhost", config, {"--call-timeout-ms", "30000"});
  for (const auto& [type, device] : components) EXPECT_NE(bound.find(std::string(type) + "0.rtc"), std::string::npos);

  Observed seen;
  auto tts = provider<URC::TextToSpeech>("TextToSpeech0", "texttospeech", "URC::TextToSpeech");
  auto voice = provider<URC::VoiceRecognition>("VoiceRecognition0", "voicerecognition", "URC::VoiceRecognition");
  ASSERT_FALSE(CORBA::is_nil(tts) || CORBA::is_nil(voice));
  URC::AudioInfo_var audio = tts->speak(kCommand);
  EXPECT_EQ(audio->sample_rate, 16000u);
  URC::RecognitionResultSeq_var results = voice->playBytes(audio->wav);
  ASSERT_GE(results->length(), 1u);
  seen.heard = results[0].text.in();
  EXPECT_EQ(seen.heard, kCommand);

  auto localizer = provider<URC::Localization>("Localizer0", "localization", "URC::Localization");
  auto robot = provider<URC::Navigation>("Robot0", "navigation", "URC::Navigation");
  ASSERT_FALSE(CORBA::is_nil(localizer) || CORBA::is_nil(robot));
  ASSERT_TRUE(wait_until(
      [&] {
        try {
          URC::PoseWithCovariance_var pose = localizer->getPose();
          return true;
        } catch (const URC::NotReady&) {
          return false;
        }
      },
      20s));
  robot->setSpeed(800);
  EXPECT_EQ(robot->speed(), 800u);
  robot->moveTo(kTargetX, kTargetY);
  ASSERT_TRUE(wait_until([&] { return robot->state() == URC::ARRIVED; }, 60s));
  const URC::Pose2D where = robot->getPosition();
  seen.position_error = std::hypot(where.x - kTargetX, where.y - kTargetY);
  EXPECT_LT(seen.position_error, 0.05);
  try {
    robot->setSpeed(5000);
    ADD_FAILURE() << "setSpeed(5000) was accepted";
  } catch (const URC::InvalidArgument& e) {
    EXPECT_STREQ(e.parameter.in(), "speed");
  }

  auto camera = provider<URC::ImageRecognition>("Camera0", "imagerecognition", "URC::ImageRecognition");
  ASSERT_FALSE(CORBA::is_nil(camera));
  EXPECT_THROW(camera->recognize(), URC::NotReady);
  camera->openCamera(0);
  URC::MarkerSeq_var markers = camera->recognize();
  std::vector<std::string> contents;
  for (CORBA::ULong i = 0; i < markers->length(); ++i) contents.emplace_back(markers[i].content.in());
  EXPECT_FALSE(contents.empty());
  seen.markers = sorted_contents(contents);
  EXPECT_EQ(seen.markers, kMarkersFacingEast);
  std::printf("RTC hosting: heard '%s', robot %.3f m from its target, markers %s\n", seen.heard.c_str(),
              seen.position_error, seen.markers.c_str());
}

}  // namespace
}  // namespace urs::test
