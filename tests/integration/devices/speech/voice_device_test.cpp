#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>

#include "TextToSpeech.pb.h"
#include "VoiceRecognition.pb.h"
#include "agent_calls.hpp"
#include "urs/audio/pcm.hpp"
#include "urs/devices/tts.hpp"
#include "urs/devices/voice.hpp"
#include "urs/devices/word_errors.hpp"

namespace urs::devices {
namespace {

using testing::call;
using testing::invalid_parameter;
using testing::not_ready_reason;
using testing::RecordingSink;
using Clock = std::chrono::steady_clock;

// Bound on the word error rate of the espeak-ng -> pocketsphinx round trip in grammar mode over
// the default robot commands (measured value printed by RoundTrip.GrammarMode...), with margin.
constexpr double kGrammarWerBound = 0.2;

// The engines load once for the whole suite: pocketsphinx takes a while per decoder.
class Speech : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    tts_ = make_tts_agent(YAML::Node());
    grammar_ = make_voice_agent(YAML::Load("{mode: grammar, decoders: 2, topic_prefix: hall/voice}"));
    grammar_->start(*sink_);
  }
  static void TearDownTestSuite() {
    grammar_->stop();
    tts_->stop();
    grammar_.reset();
    tts_.reset();
  }

  static std::string spoken(const std::string& text) {
    URC::TextToSpeech_speak_Request request;
    request.set_text(text);
    URC::TextToSpeech_speak_Reply reply;
    const auto outcome = call(*tts_, *sink_, "speak", request, reply);
    EXPECT_EQ(outcome.status, call::Status::OK) << outcome.message;
    return reply.result().wav();
  }

  static agent::Outcome play_bytes(agent::ServiceAgent& voice, const std::string& wav, URC::RecognitionResult* best,
                                   std::chrono::milliseconds deadline = std::chrono::seconds(60)) {
    URC::VoiceRecognition_playBytes_Request request;
    request.set_wave(wav);
    URC::VoiceRecognition_playBytes_Reply reply;
    auto outcome = call(voice, *sink_, "playBytes", request, reply, deadline);
    if (best != nullptr && reply.result_size() > 0) *best = reply.result(0);
    return outcome;
  }

  static std::string recognised(agent::ServiceAgent& voice, const std::string& wav) {
    URC::RecognitionResult best;
    const auto outcome = play_bytes(voice, wav, &best);
    EXPECT_EQ(outcome.status, call::Status::OK) << outcome.message;
    return best.text();
  }

  static agent::Outcome start_stream(uint32_t rate, uint32_t channels, uint32_t& id) {
    URC::VoiceRecognition_startStream_Request request;
    request.mutable_format()->set_sample_rate(rate);
    request.mutable_format()->set_channels(channels);
    URC::VoiceRecognition_startStream_Reply reply;
    auto outcome = call(*grammar_, *sink_, "startStream", request, reply);
    id = reply.result();
    return outcome;
  }

  static agent::Outcome feed(uint32_t id, const std::string& pcm) {
    URC::VoiceRecognition_feedStream_Request request;
    request.set_stream(id);
    request.set_pcm(pcm);
    URC::VoiceRecognition_feedStream_Reply reply;
    return call(*grammar_, *sink_, "feedStream", request, reply);
  }

  static agent::Outcome finish(uint32_t id, std::string& text) {
    URC::VoiceRecognition_finishStream_Request request;
    request.set_stream(id);
    URC::VoiceRecognition_finishStream_Reply reply;
    auto outcome = call(*grammar_, *sink_, "finishStream", request, reply);
    if (reply.result_size() > 0) text = reply.result(0).text();
    return outcome;
  }

  static std::string pcm_bytes(const std::vector<int16_t>& samples) {
    const std::string wav = audio::encode_wav(audio::Pcm{16000, 1, samples});
    return wav.substr(44);
  }

  static inline std::shared_ptr<RecordingSink> sink_ = std::make_shared<RecordingSink>();
  static inline std::shared_ptr<agent::ServiceAgent> tts_;
  static inline std::shared_ptr<agent::ServiceAgent> grammar_;
};

// Every default robot command, spoken by the TTS device, recognised by the grammar-mode device.
TEST_F(Speech, RoundTripGrammarModeRecognisesTheRobotCommands) {
  WordErrors total;
  double audio_s = 0;
  const auto started = Clock::now();
  for (const auto& command : default_robot_commands()) {
    const std::string wav = spoken(command);
    audio_s += audio::decode_wav(wav).duration();
    const std::string text = recognised(*grammar_, wav);
    const WordErrors errors = align_words(command, text);
    total += errors;
    std::printf("  %-24s -> %-24s (%zu error(s))\n", command.c_str(), text.c_str(), errors.errors());
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
  std::printf(
      "grammar mode: WER %.3f (S %zu, D %zu, I %zu, N %zu) over %zu commands; %.2f s of speech synthesised "
      "and recognised in %.2f s\n",
      total.rate(), total.substitutions, total.deletions, total.insertions, total.reference_words,
      default_robot_commands().size(), audio_s, seconds);
  EXPECT_LE(total.rate(), kGrammarWerBound);
}

// The same round trip through the full language model: free dictation, so only reported.
TEST_F(Speech, RoundTripFullLanguageModelIsMeasured) {
  const auto lm = make_voice_agent(YAML::Load("{mode: lm, decoders: 1}"));
  WordErrors total;
  for (const auto& command : default_robot_commands()) {
    const std::string text = recognised(*lm, spoken(command));
    const WordErrors errors = align_words(command, text);
    total += errors;
    std::printf("  %-24s -> %-24s (%zu error(s))\n", command.c_str(), text.c_str(), errors.errors());
  }
  std::printf("full-LM mode: WER %.3f (S %zu, D %zu, I %zu, N %zu)\n", total.rate(), total.substitutions,
              total.deletions, total.insertions, total.reference_words);
  lm->stop();
}

TEST_F(Speech, ResultsCarryConfidenceAndStampAndArePublished) {
  const auto before = std::chrono::system_clock::now();
  URC::RecognitionResult best;
  ASSERT_EQ(play_bytes(*grammar_, spoken("turn left"), &best).status, call::Status::OK);
  EXPECT_EQ(best.text(), "turn left");
  EXPECT_GT(best.confidence(), 0.0f);
  EXPECT_LE(best.confidence(), 1.0f);
  EXPECT_GE(best.stamp().sec(), std::chrono::duration_cast<std::chrono::seconds>(before.time_since_epoch()).count());
  EXPECT_LT(best.stamp().nsec(), 1000000000u);
  std::printf("'turn left': confidence %.3f\n", best.confidence());

  bool published = false;
  for (const auto& [topic, payload] : sink_->events()) {
    URC::RecognitionResult event;
    if (topic == "hall/voice/recognized" && event.ParseFromString(payload) && event.text() == "turn left") {
      published = true;
    }
  }
  EXPECT_TRUE(published);
}

TEST_F(Speech, SilenceGivesAnEmptyResult) {
  URC::RecognitionResult best;
  ASSERT_EQ(play_bytes(*grammar_, audio::encode_wav(audio::Pcm{16000, 1, std::vector<int16_t>(16000)}), &best).status,
            call::Status::OK);
  EXPECT_EQ(best.text(), "");
}

TEST_F(Speech, StreamingInHundredMillisecondChunksGivesTheSameTextAsPlayBytes) {
  for (const std::string command : {"go to the kitchen", "speak louder"}) {
    const std::string wav = spoken(command);
    const std::string whole = recognised(*grammar_, wav);
    const std::string pcm = wav.substr(44);
    uint32_t id = 0;
    ASSERT_EQ(start_stream(16000, 1, id).status, call::Status::OK);
    for (std::size_t at = 0; at < pcm.size(); at += 3200)
      ASSERT_EQ(feed(id, pcm.substr(at, 3200)).status, call::Status::OK);
    std::string streamed;
    ASSERT_EQ(finish(id, streamed).status, call::Status::OK);
    EXPECT_EQ(streamed, whole);
    EXPECT_EQ(streamed, command);
  }
}

TEST_F(Speech, ConcurrentStreamsKeepTheirOwnAudio) {
  const std::string left = spoken("turn left").substr(44);
  const std::string right = spoken("go to the living room").substr(44);
  uint32_t a = 0, b = 0;
  ASSERT_EQ(start_stream(16000, 1, a).status, call::Status::OK);
  ASSERT_EQ(start_stream(16000, 1, b).status, call::Status::OK);
  EXPECT_NE(a, b);
  for (std::size_t at = 0; at < std::max(left.size(), right.size()); at += 3200) {
    if (at < left.size()) {
      ASSERT_EQ(feed(a, left.substr(at, 3200)).status, call::Status::OK);
    }
    if (at < right.size()) {
      ASSERT_EQ(feed(b, right.substr(at, 3200)).status, call::Status::OK);
    }
  }
  std::string text_a, text_b;
  ASSERT_EQ(finish(b, text_b).status, call::Status::OK);
  ASSERT_EQ(finish(a, text_a).status, call::Status::OK);
  EXPECT_EQ(text_a, "turn left");
  EXPECT_EQ(text_b, "go to the living room");
}

TEST_F(Speech, OtherRatesAndStereoAreConverted) {
  const audio::Pcm mono = audio::decode_wav(spoken("come here"));
  const auto at_44k = audio::resample(mono.samples, 16000, 44100);
  audio::Pcm stereo{44100, 2, {}};
  for (int16_t s : at_44k) {
    stereo.samples.push_back(s);
    stereo.samples.push_back(static_cast<int16_t>(s / 2));
  }
  EXPECT_EQ(recognised(*grammar_, audio::encode_wav(stereo)), "come here");

  uint32_t id = 0;
  ASSERT_EQ(start_stream(44100, 2, id).status, call::Status::OK);
  const std::string pcm = audio::encode_wav(stereo).substr(44);
  for (std::size_t at = 0; at < pcm.size(); at += 17640)
    ASSERT_EQ(feed(id, pcm.substr(at, 17640)).status, call::Status::OK);
  std::string text;
  ASSERT_EQ(finish(id, text).status, call::Status::OK);
  EXPECT_EQ(text, "come here");
}

TEST_F(Speech, PlayFileReadsAWavOnTheDevicesHost) {
  const std::string path = ::testing::TempDir() + "/speech_play_file.wav";
  std::ofstream(path, std::ios::binary) << spoken("follow me");
  URC::VoiceRecognition_playFile_Request request;
  request.set_path(path);
  URC::VoiceRecognition_playFile_Reply reply;
  ASSERT_EQ(call(*grammar_, *sink_, "playFile", request, reply).status, call::Status::OK);
  ASSERT_EQ(reply.result_size(), 1);
  EXPECT_EQ(reply.result(0).text(), "follow me");
  std::remove(path.c_str());

  request.set_path(path + ".missing");
  EXPECT_EQ(invalid_parameter(call(*grammar_, *sink_, "playFile", request, reply)), "path");
}

TEST_F(Speech, BadInputsNameTheirParameter) {
  EXPECT_EQ(invalid_parameter(play_bytes(*grammar_, "RIFF....WAVEjunk", nullptr)), "wave");
  std::string eight_bit = audio::encode_wav(audio::Pcm{16000, 1, std::vector<int16_t>(100)});
  eight_bit[34] = 8;
  EXPECT_EQ(invalid_parameter(play_bytes(*grammar_, eight_bit, nullptr)), "wave");
  EXPECT_EQ(invalid_parameter(play_bytes(
                *grammar_, audio::encode_wav(audio::Pcm{16000, 1, std::vector<int16_t>(16000 * 61)}), nullptr)),
            "wave");

  uint32_t id = 0;
  EXPECT_EQ(invalid_parameter(start_stream(4000, 1, id)), "format");
  EXPECT_EQ(invalid_parameter(start_stream(16000, 3, id)), "format");
  EXPECT_EQ(invalid_parameter(feed(999999, "ab")), "stream");
  std::string text;
  EXPECT_EQ(invalid_parameter(finish(999999, text)), "stream");

  ASSERT_EQ(start_stream(16000, 2, id).status, call::Status::OK);
  EXPECT_EQ(invalid_parameter(feed(id, "abc")), "pcm");
  EXPECT_EQ(invalid_parameter(feed(id, "ab")), "pcm") << "half a stereo frame";
  ASSERT_EQ(finish(id, text).status, call::Status::OK);
  EXPECT_EQ(invalid_parameter(finish(id, text)), "stream") << "a finished stream is gone";
}

TEST_F(Speech, CancelAllClosesOpenStreams) {
  uint32_t id = 0;
  ASSERT_EQ(start_stream(16000, 1, id).status, call::Status::OK);
  ASSERT_EQ(feed(id, pcm_bytes(std::vector<int16_t>(1600))).status, call::Status::OK);
  URC::VoiceRecognition_cancelAll_Request cancel;
  cancel.set_details("operator reset");
  URC::VoiceRecognition_cancelAll_Reply done;
  ASSERT_EQ(call(*grammar_, *sink_, "cancelAll", cancel, done).status, call::Status::OK);
  EXPECT_EQ(invalid_parameter(feed(id, pcm_bytes(std::vector<int16_t>(1600)))), "stream");
  EXPECT_EQ(recognised(*grammar_, spoken("stop")), "stop") << "decoders are free again";
}

TEST_F(Speech, BusyDecodersAnswerNotReady) {
  const auto single = make_voice_agent(YAML::Load("{decoders: 1, commands: [stop, go]}"));
  URC::VoiceRecognition_startStream_Request request;
  request.mutable_format()->set_sample_rate(16000);
  request.mutable_format()->set_channels(1);
  URC::VoiceRecognition_startStream_Reply reply;
  ASSERT_EQ(call(*single, *sink_, "startStream", request, reply).status, call::Status::OK);
  const auto outcome = play_bytes(*single, spoken("stop"), nullptr, std::chrono::milliseconds(300));
  EXPECT_THAT(not_ready_reason(outcome), ::testing::HasSubstr("decoders are busy"));
  single->stop();  // closes the stream, which frees the decoder
  URC::RecognitionResult best;
  ASSERT_EQ(play_bytes(*single, spoken("go"), &best).status, call::Status::OK);
  EXPECT_EQ(best.text(), "go");
}

TEST(VoiceDeviceConfig, RefusesWordsOutsideTheDictionaryAndAMissingModel) {
  EXPECT_THAT(
      testing::config_error_of([] { make_voice_agent(YAML::Load("{decoders: 1, commands: [go to the zorblax]}")); }),
      ::testing::HasSubstr("commands: words not in the dictionary: zorblax"));
  EXPECT_THAT(testing::config_error_of([] { make_voice_agent(YAML::Load("{decoders: 1, model_dir: no/such/model}")); }),
              ::testing::HasSubstr("model_dir: "));
}

}  // namespace
}  // namespace urs::devices
