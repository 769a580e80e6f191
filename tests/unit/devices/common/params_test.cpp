// The params reader every device shares (urs/devices/params.hpp), then each device's params read
// through it: defaults, every setting, and every mistake named by its key.

#include "urs/devices/params.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <vector>

#include "urs/camera/camera_agent.hpp"
#include "urs/devices/localizer.hpp"
#include "urs/devices/robot.hpp"
#include "urs/devices/tts.hpp"
#include "urs/devices/voice.hpp"

namespace urs::devices {
namespace {

using ::testing::AllOf;
using ::testing::Contains;
using ::testing::ElementsAre;
using ::testing::Field;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

// The problems `parse` refused its params with; empty if it accepted them.
std::vector<ParamProblem> problems_of(const std::function<void()>& parse) {
  try {
    parse();
  } catch (const ParamError& e) {
    return e.problems();
  }
  return {};
}

// A problem with this key whose text contains `what`.
auto problem(const std::string& key, const std::string& what) {
  return AllOf(Field(&ParamProblem::key, key), Field(&ParamProblem::what, HasSubstr(what)));
}

// ---- the reader ---------------------------------------------------------------------------------

TEST(ParamReader, AbsentKeysTakeTheirFallbacks) {
  ParamReader p("thing", YAML::Node(), {"n", "s"});
  EXPECT_DOUBLE_EQ(p.number("n", 2.5, 0, 10), 2.5);
  EXPECT_EQ(p.text("s", "x"), "x");
  EXPECT_EQ(p.integer("i", 7, 0, 10), 7);
  EXPECT_EQ(p.text_list("l", {"a"}), std::vector<std::string>{"a"});
  EXPECT_FALSE(p.section("m", {}));
  EXPECT_THAT(p.sections("m", {}), IsEmpty());
  EXPECT_FALSE(p.failed());
  EXPECT_NO_THROW(p.finish());
}

TEST(ParamReader, ReadsEveryKind) {
  ParamReader p("thing", YAML::Load("{n: 2.5, i: 3, s: hi, c: b, d: 7, l: [x, y], m: {k: 1}, ms: [{k: 2}, {k: 3}]}"),
                {"n", "i", "s", "c", "d", "l", "m", "ms"});
  EXPECT_DOUBLE_EQ(p.number("n", 0, 0, 10), 2.5);
  EXPECT_EQ(p.integer("i", 0, 0, 10), 3);
  EXPECT_EQ(p.text("s", ""), "hi");
  EXPECT_EQ(p.choice("c", "a", {"a", "b"}), "b");
  EXPECT_EQ(p.domain("d", 0), 7u);
  EXPECT_EQ(p.text_list("l", {}), (std::vector<std::string>{"x", "y"}));
  auto m = p.section("m", {"k"});
  ASSERT_TRUE(m);
  EXPECT_EQ(m->integer("k", 0, 0, 9), 1);
  std::vector<int> ks;
  for (auto& entry : p.sections("ms", {"k"})) ks.push_back(entry.integer("k", 0, 0, 9));
  EXPECT_EQ(ks, (std::vector<int>{2, 3}));
  EXPECT_NO_THROW(p.finish());
}

TEST(ParamReader, EveryMistakeIsNamedByItsKeyPathAndAllAreThrownTogether) {
  const YAML::Node params = YAML::Load(R"(
    big: 5000
    nan: .nan
    word: fast
    half: 1.5
    empty: ''
    pick: gps
    dom: 300
    list: go
    items: [a, [b]]
    nested: {inner: 12, stray: 1}
    entries: [{k: 1}, 5, {k: x}]
    whole: {a: 1}
    extra: 1
  )");
  ParamReader p("thing", params,
                {"big", "nan", "word", "half", "empty", "pick", "dom", "list", "items", "nested", "entries", "whole"});
  EXPECT_DOUBLE_EQ(p.number("big", 1, 0, 1200), 1);  // the fallback
  p.number("nan", 1, 0, 10);
  p.number("word", 1, 0, 10);
  p.integer("half", 1, 0, 10);
  EXPECT_EQ(p.text("empty", "keep"), "keep");
  EXPECT_EQ(p.choice("pick", "localizer", {"localizer", "ground_truth"}), "localizer");
  p.domain("dom", 0);
  p.text_list("list", {});
  p.text_list("items", {});
  if (auto nested = p.section("nested", {"inner"})) nested->integer("inner", 0, 0, 10);
  for (auto& entry : p.sections("entries", {"k"})) entry.integer("k", 0, 0, 9);
  p.number("whole", 0, 0, 1);
  EXPECT_TRUE(p.failed());

  const auto problems = problems_of([&] { p.finish(); });
  EXPECT_THAT(problems, Contains(problem("big", "'5000' is outside 0 .. 1200")));
  EXPECT_THAT(problems, Contains(problem("nan", "'.nan' is not a number")));
  EXPECT_THAT(problems, Contains(problem("word", "'fast' is not a number")));
  EXPECT_THAT(problems, Contains(problem("half", "'1.5' is not a whole number")));
  EXPECT_THAT(problems, Contains(problem("empty", "must not be empty")));
  EXPECT_THAT(problems, Contains(problem("pick", "'gps' is not one of ground_truth, localizer")));
  EXPECT_THAT(problems, Contains(problem("dom", "'300' is outside 0 .. 232")));
  EXPECT_THAT(problems, Contains(problem("list", "must be a list of strings")));
  EXPECT_THAT(problems, Contains(problem("items[1]", "must be a string")));
  EXPECT_THAT(problems, Contains(problem("nested.inner", "'12' is outside 0 .. 10")));
  EXPECT_THAT(problems, Contains(problem("nested.stray", "unknown key (allowed: inner)")));
  EXPECT_THAT(problems, Contains(problem("entries[1]", "must be a map (keys: k)")));
  EXPECT_THAT(problems, Contains(problem("entries[2].k", "'x' is not a number")));
  EXPECT_THAT(problems, Contains(problem("whole", "must be a number")));
  EXPECT_THAT(problems, Contains(problem("extra", "unknown key")));
  EXPECT_EQ(problems.size(), 15u);

  try {
    p.finish();
    FAIL() << "finish() accepted mistakes";
  } catch (const util::ConfigError& e) {  // what hosts catch
    EXPECT_THAT(e.what(), HasSubstr("thing params: 15 error(s):\n  extra: unknown key (allowed: big, dom,"));
    EXPECT_THAT(e.what(), HasSubstr("\n  big: '5000' is outside 0 .. 1200\n"));
  }
}

TEST(ParamReader, ParamsThatAreNotAMapAreOneProblem) {
  const auto problems = problems_of([] { ParamReader("thing", YAML::Load("[1, 2]"), {"a", "b"}).finish(); });
  EXPECT_THAT(problems, ElementsAre(problem("", "must be a map (keys: a, b)")));
  try {
    ParamReader("thing", YAML::Load("7"), {"a"}).finish();
  } catch (const ParamError& e) {
    EXPECT_EQ(e.device(), "thing");
    EXPECT_THAT(e.what(), HasSubstr("\n  params: must be a map"));
  }
}

// ---- robot and localizer ------------------------------------------------------------------------

TEST(RobotParams, DefaultsAreAP3dxClosingItsLoopOnTheLocalizer) {
  const RobotConfig c = parse_robot_config(YAML::Node());
  EXPECT_EQ(c.name, "robot");
  EXPECT_EQ(c.prefix, "robot");
  EXPECT_EQ(c.domain, 0u);
  EXPECT_DOUBLE_EQ(c.limits.max_speed, 1.2);
  EXPECT_DOUBLE_EQ(c.speed, 0.5);
  EXPECT_EQ(c.feedback, RobotConfig::Feedback::localizer);
  const RobotConfig named =
      parse_robot_config(YAML::Load("{name: p3dx, max_speed: 800, speed: 200, feedback: ground_truth}"));
  EXPECT_EQ(named.prefix, "p3dx");
  EXPECT_DOUBLE_EQ(named.limits.max_speed, 0.8);
  EXPECT_DOUBLE_EQ(named.speed, 0.2);
  EXPECT_EQ(named.feedback, RobotConfig::Feedback::ground_truth);
}

TEST(RobotParams, EveryMistakeIsNamedByItsKey) {
  const auto problems = problems_of(
      [] { parse_robot_config(YAML::Load("{speed: 5000, domain: 1.5, feedback: gps, wheels: 4, time_scale: .nan}")); });
  EXPECT_EQ(problems.size(), 5u);
  EXPECT_THAT(problems, Contains(problem("speed", "'5000' is outside 0 .. 1200")));  // up to max_speed
  EXPECT_THAT(problems, Contains(problem("domain", "not a whole number")));
  EXPECT_THAT(problems, Contains(problem("feedback", "'gps' is not one of")));
  EXPECT_THAT(problems, Contains(problem("wheels", "unknown key")));
  EXPECT_THAT(problems, Contains(problem("time_scale", "not a number")));
  EXPECT_THAT(problems_of([] { parse_robot_config(YAML::Load("{max_speed: 1500}")); }),
              ElementsAre(problem("max_speed", "'1500' is outside 1 .. 1200")));
}

TEST(LocalizerParams, DefaultsAndMistakes) {
  const auto c = parse_localizer_config(YAML::Node());
  EXPECT_EQ(c.robot, "robot");
  EXPECT_EQ(c.prefix, "localizer");
  EXPECT_DOUBLE_EQ(c.rate, 10);
  EXPECT_DOUBLE_EQ(c.noise_xy, 0.02);
  EXPECT_DOUBLE_EQ(c.noise_theta, 0.01);
  EXPECT_EQ(parse_localizer_config(YAML::Load("{seed: 4294967295}")).seed, 4294967295u);
  EXPECT_THAT(problems_of([] { parse_localizer_config(YAML::Load("{rate: 0, robot: '', seed: -1}")); }),
              ElementsAre(problem("robot", "must not be empty"), problem("rate", "'0' is outside"),
                          problem("seed", "'-1' is outside 0 .. 4294967295")));
}

// ---- speech -------------------------------------------------------------------------------------

TEST(TtsParams, DefaultsAndValues) {
  const TtsParams defaults = parse_tts_params(YAML::Node());
  EXPECT_EQ(defaults.voice, "en-us");
  EXPECT_EQ(defaults.topic_prefix, "tts");
  const TtsParams set = parse_tts_params(
      YAML::Load("{voice: en-gb, rate: 140, max_text_length: 50, max_queue: 2, topic_prefix: hall/tts}"));
  EXPECT_EQ(set.voice, "en-gb");
  EXPECT_EQ(set.rate, 140);
  EXPECT_EQ(set.max_text_length, 50u);
  EXPECT_EQ(set.max_queue, 2u);
  EXPECT_EQ(set.topic_prefix, "hall/tts");
}

TEST(TtsParams, EveryMistakeIsNamedByItsKey) {
  const auto problems =
      problems_of([] { parse_tts_params(YAML::Load("{rate: 20, max_queue: lots, volume: 3, topic_prefix: ''}")); });
  EXPECT_EQ(problems.size(), 4u);
  EXPECT_THAT(problems, Contains(problem("rate", "'20' is outside 80 .. 450")));
  EXPECT_THAT(problems, Contains(problem("max_queue", "'lots' is not a number")));
  EXPECT_THAT(problems, Contains(problem("volume", "unknown key")));
  EXPECT_THAT(problems, Contains(problem("topic_prefix", "must not be empty")));
}

TEST(VoiceParams, DefaultsToGrammarModeWithTheRobotCommands) {
  const VoiceParams params = parse_voice_params(YAML::Node());
  EXPECT_EQ(params.mode, RecognitionMode::grammar);
  EXPECT_EQ(params.commands, default_robot_commands());
  EXPECT_FALSE(params.model_dir.empty());
  EXPECT_EQ(params.decoders, 2u);
}

TEST(VoiceParams, NormalisesCommands) {
  const VoiceParams params = parse_voice_params(
      YAML::Load("{mode: grammar, commands: ['  Go   Forward ', stop, 'go forward', \"don't move\"]}"));
  EXPECT_EQ(params.commands, (std::vector<std::string>{"go forward", "stop", "don't move"}));
  EXPECT_EQ(parse_voice_params(YAML::Load("{mode: lm}")).mode, RecognitionMode::lm);
}

TEST(VoiceParams, EveryMistakeIsNamedByItsKey) {
  const auto problems = problems_of([] {
    parse_voice_params(YAML::Load("{mode: dictation, commands: ['go to room 5'], decoders: 0, max_audio_s: -1}"));
  });
  EXPECT_EQ(problems.size(), 4u);
  EXPECT_THAT(problems, Contains(problem("mode", "'dictation' is not one of grammar, lm")));
  EXPECT_THAT(problems, Contains(problem("commands", "'go to room 5' has a word other than letters")));
  EXPECT_THAT(problems, Contains(problem("decoders", "'0' is outside 1 .. 8")));
  EXPECT_THAT(problems, Contains(problem("max_audio_s", "'-1' is outside 1 .. 600")));
  EXPECT_THAT(problems_of([] { parse_voice_params(YAML::Load("{commands: []}")); }),
              ElementsAre(problem("commands", "must not be an empty list")));
  EXPECT_THAT(problems_of([] { parse_voice_params(YAML::Load("{commands: go}")); }),
              ElementsAre(problem("commands", "must be a list of strings")));
}

// ---- camera -------------------------------------------------------------------------------------

TEST(CameraParams, DefaultsAreTheLabSeenFromItsCentre) {
  const camera::CameraParams params = camera::parse_camera_params(YAML::Node());
  ASSERT_TRUE(params.scene);
  EXPECT_EQ(params.scene->world().markers.size(), 6u);
  EXPECT_EQ(params.scene->camera().width, 640u);
  EXPECT_EQ(params.scene->camera().height, 480u);
  EXPECT_DOUBLE_EQ(params.pose.x, 3.25);
  EXPECT_EQ(params.event_prefix, "camera");
  EXPECT_EQ(params.device, 0u);
  EXPECT_FALSE(params.world);
}

TEST(CameraParams, EverySettingIsRead) {
  const camera::CameraParams params = camera::parse_camera_params(YAML::Load(R"(
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
  const auto world = camera::parse_camera_params(YAML::Load("world: {domain: 4, robot: robot1}")).world;
  ASSERT_TRUE(world);
  EXPECT_EQ(world->domain, 4u);
  EXPECT_EQ(world->robot, "robot1");
}

TEST(CameraParams, EveryMistakeIsNamedByItsKey) {
  const auto problems = problems_of([] {
    camera::parse_camera_params(YAML::Load(R"(
      lens: wide
      scan_hz: 100
      pose: {x: east}
      camera: {width: -3, zoom: 2}
      markers: [{x: 1, y: 0}]
    )"));
  });
  EXPECT_EQ(problems.size(), 6u);
  EXPECT_THAT(problems, Contains(problem("lens", "unknown key")));
  EXPECT_THAT(problems, Contains(problem("scan_hz", "'100' is outside 0 .. 30")));
  EXPECT_THAT(problems, Contains(problem("pose.x", "'east' is not a number")));
  EXPECT_THAT(problems, Contains(problem("camera.width", "'-3' is outside 16 .. 4096")));
  EXPECT_THAT(problems, Contains(problem("camera.zoom", "unknown key")));
  EXPECT_THAT(problems, Contains(problem("markers[0].id", "required")));
  EXPECT_THAT(problems_of([] { camera::parse_camera_params(YAML::Load("markers: [{id: 4, x: 2, y: 2}]")); }),
              ElementsAre(problem("markers", "marker 4: (2.000000, 2.000000) is not on a wall")));
  const auto world = problems_of([] { camera::parse_camera_params(YAML::Load("world: {domain: 300}\npose: {x: 1}")); });
  EXPECT_THAT(world, Contains(problem("world.robot", "required")));
  EXPECT_THAT(world, Contains(problem("world.domain", "'300' is outside 0 .. 232")));
  EXPECT_THAT(world, Contains(problem("pose", "not allowed with world")));
  EXPECT_THAT(problems_of([] { camera::parse_camera_params(YAML::Load("room: {width: 0}")); }),
              ElementsAre(problem("room.width", "'0' is outside 0.1 .. 1000")));
}

}  // namespace
}  // namespace urs::devices
