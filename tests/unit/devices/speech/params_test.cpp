#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "urs/devices/tts.hpp"
#include "urs/devices/voice.hpp"
#include "urs/util/cli.hpp"

namespace urs::devices {
namespace {

using ::testing::HasSubstr;

std::string config_error_of(const std::function<void()>& parse) {
  try {
    parse();
  } catch (const util::ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(TtsParams, DefaultsAndValues) {
  const TtsParams defaults = parse_tts_params(YAML::Node());
  EXPECT_EQ(defaults.voice, "en-us");
  EXPECT_EQ(defaults.topic_prefix, "tts");
  const TtsParams set = parse_tts_params(YAML::Load("{voice: en-gb, rate: 140, max_text_length: 50, max_queue: 2, topic_prefix: hall/tts}"));
  EXPECT_EQ(set.voice, "en-gb");
  EXPECT_EQ(set.rate, 140);
  EXPECT_EQ(set.max_text_length, 50u);
  EXPECT_EQ(set.max_queue, 2u);
  EXPECT_EQ(set.topic_prefix, "hall/tts");
}

TEST(TtsParams, NamesEveryBadKey) {
  const std::string error = config_error_of(
      [] { parse_tts_params(YAML::Load("{rate: 20, max_queue: lots, volume: 3, topic_prefix: ''}")); });
  EXPECT_THAT(error, HasSubstr("rate: 20 is outside 80..450"));
  EXPECT_THAT(error, HasSubstr("max_queue: "));
  EXPECT_THAT(error, HasSubstr("volume: unknown key"));
  EXPECT_THAT(error, HasSubstr("topic_prefix: must not be empty"));
  EXPECT_THAT(config_error_of([] { parse_tts_params(YAML::Load("[1, 2]")); }), HasSubstr("params: must be a map"));
}

TEST(VoiceParams, DefaultsToGrammarModeWithTheRobotCommands) {
  const VoiceParams params = parse_voice_params(YAML::Node());
  EXPECT_EQ(params.mode, RecognitionMode::grammar);
  EXPECT_EQ(params.commands, default_robot_commands());
  EXPECT_FALSE(params.model_dir.empty());
  EXPECT_EQ(params.decoders, 2u);
}

TEST(VoiceParams, NormalisesCommands) {
  const VoiceParams params =
      parse_voice_params(YAML::Load("{mode: grammar, commands: ['  Go   Forward ', stop, 'go forward', \"don't move\"]}"));
  EXPECT_EQ(params.commands, (std::vector<std::string>{"go forward", "stop", "don't move"}));
  EXPECT_EQ(parse_voice_params(YAML::Load("{mode: lm}")).mode, RecognitionMode::lm);
}

TEST(VoiceParams, NamesEveryBadKey) {
  const std::string error = config_error_of([] {
    parse_voice_params(YAML::Load("{mode: dictation, commands: ['go to room 5'], decoders: 0, max_audio_s: -1}"));
  });
  EXPECT_THAT(error, HasSubstr("mode: 'dictation' is not grammar or lm"));
  EXPECT_THAT(error, HasSubstr("commands: 'go to room 5' has a word other than letters"));
  EXPECT_THAT(error, HasSubstr("decoders: 0 is outside 1..8"));
  EXPECT_THAT(error, HasSubstr("max_audio_s: "));
  EXPECT_THAT(config_error_of([] { parse_voice_params(YAML::Load("{commands: []}")); }),
              HasSubstr("commands: must list at least one command"));
  EXPECT_THAT(config_error_of([] { parse_voice_params(YAML::Load("{commands: go}")); }),
              HasSubstr("commands: must be a list of strings"));
}

}  // namespace
}  // namespace urs::devices
