#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <condition_variable>
#include <future>
#include <mutex>

#include "TextToSpeech.pb.h"
#include "agent_calls.hpp"
#include "urs/audio/pcm.hpp"
#include "urs/devices/tts.hpp"

namespace urs::devices {
namespace {

using testing::call;
using testing::invalid_parameter;
using testing::not_ready_reason;
using testing::RecordingSink;

class TtsDevice : public ::testing::Test {
 protected:
  void SetUp() override {
    agent_ = make_tts_agent(YAML::Load("{topic_prefix: hall/tts, max_text_length: 2000}"));
    agent_->start(sink_);
  }
  void TearDown() override { agent_->stop(); }

  agent::Outcome speak(const std::string& text, URC::AudioInfo* info = nullptr) {
    URC::TextToSpeech_speak_Request request;
    request.set_text(text);
    URC::TextToSpeech_speak_Reply reply;
    auto outcome = call(*agent_, sink_, "speak", request, reply);
    if (info != nullptr) *info = reply.result();
    return outcome;
  }

  RecordingSink sink_;
  std::shared_ptr<agent::ServiceAgent> agent_;
};

TEST_F(TtsDevice, SpeaksACompleteSixteenKilohertzMonoWav) {
  URC::AudioInfo info;
  ASSERT_EQ(speak("Go to the kitchen, please.", &info).status, call::Status::OK);
  EXPECT_EQ(info.sample_rate(), 16000u);
  EXPECT_EQ(info.channels(), 1u);
  EXPECT_EQ(info.bits_per_sample(), 16u);
  EXPECT_GT(info.duration(), 0.5);
  EXPECT_LT(info.duration(), 5.0);

  const std::string& wav = info.wav();
  ASSERT_GT(wav.size(), 44u);
  EXPECT_EQ(wav.substr(0, 4), "RIFF");
  EXPECT_EQ(wav.substr(8, 4), "WAVE");
  const audio::Pcm pcm = audio::decode_wav(wav);
  EXPECT_EQ(pcm.sample_rate, 16000u);
  EXPECT_EQ(pcm.channels, 1u);
  EXPECT_DOUBLE_EQ(pcm.duration(), info.duration());
  int16_t peak = 0;
  for (int16_t s : pcm.samples) peak = std::max<int16_t>(peak, static_cast<int16_t>(std::abs(s)));
  EXPECT_GT(peak, 1000) << "the speech is audible, not silence";
  std::printf("speak: %.2f s of audio, %zu bytes of WAV\n", info.duration(), wav.size());

  const auto events = sink_.events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].first, "hall/tts/spoken");
  URC::TextToSpeech_speak_Request spoken;
  ASSERT_TRUE(spoken.ParseFromString(events[0].second));
  EXPECT_EQ(spoken.text(), "Go to the kitchen, please.");
}

TEST_F(TtsDevice, ListsVoicesAndSwitchesBetweenThem) {
  URC::TextToSpeech_getAvailableVoices_Reply voices;
  ASSERT_EQ(call(*agent_, sink_, "getAvailableVoices", URC::TextToSpeech_getAvailableVoices_Request(), voices).status,
            call::Status::OK);
  ASSERT_GT(voices.result_size(), 10);
  bool us_english = false;
  for (const auto& v : voices.result()) {
    if (v.name() == "en-us") {
      us_english = true;
      EXPECT_EQ(v.language(), "en-US");
    }
  }
  EXPECT_TRUE(us_english);

  URC::TextToSpeech__get_voice_Reply current;
  ASSERT_EQ(call(*agent_, sink_, "_get_voice", URC::TextToSpeech__get_voice_Request(), current).status,
            call::Status::OK);
  EXPECT_EQ(current.result(), "en-us");

  URC::TextToSpeech_setVoice_Request set;
  URC::TextToSpeech_setVoice_Reply done;
  set.set_name("de");
  ASSERT_EQ(call(*agent_, sink_, "setVoice", set, done).status, call::Status::OK);
  ASSERT_EQ(call(*agent_, sink_, "_get_voice", URC::TextToSpeech__get_voice_Request(), current).status,
            call::Status::OK);
  EXPECT_EQ(current.result(), "de");
  EXPECT_EQ(speak("Guten Tag").status, call::Status::OK);

  set.set_name("klingon");
  const auto refused = call(*agent_, sink_, "setVoice", set, done);
  EXPECT_EQ(refused.status, call::Status::USER_EXCEPTION);
  EXPECT_EQ(invalid_parameter(refused), "name");
  ASSERT_EQ(call(*agent_, sink_, "_get_voice", URC::TextToSpeech__get_voice_Request(), current).status,
            call::Status::OK);
  EXPECT_EQ(current.result(), "de");
}

TEST_F(TtsDevice, RefusesEmptyAndOverlongText) {
  EXPECT_EQ(invalid_parameter(speak("")), "text");
  EXPECT_EQ(invalid_parameter(speak("  \n ")), "text");
  EXPECT_EQ(invalid_parameter(speak(std::string(2001, 'a'))), "text");
  EXPECT_TRUE(sink_.events().empty());
}

TEST_F(TtsDevice, CancelAllAnswersEveryWaitingUtteranceAndKeepsWorking) {
  // Six long utterances asked at once of a device whose queue holds three: one is being spoken,
  // three wait, the rest are refused. A refusal shows the queue full, so cancelAll, sent then, has
  // waiting utterances to answer.
  agent_->stop();
  agent_ = make_tts_agent(YAML::Load("{topic_prefix: hall/tts, max_text_length: 2000, max_queue: 3}"));
  agent_->start(sink_);
  std::string long_text;
  while (long_text.size() + 20 < 2000) long_text += "turn left and then ";
  std::mutex mutex;
  std::condition_variable answered;
  int refused = 0;
  const auto speak_long = [&] {
    agent::Outcome outcome = speak(long_text);
    if (not_ready_reason(outcome).find("already waiting") != std::string::npos) {
      std::lock_guard lock(mutex);
      ++refused;
      answered.notify_all();
    }
    return outcome;
  };
  std::vector<std::future<agent::Outcome>> calls;
  for (int i = 0; i < 6; ++i) calls.push_back(std::async(std::launch::async, speak_long));
  {
    std::unique_lock lock(mutex);
    ASSERT_TRUE(answered.wait_for(lock, std::chrono::seconds(30), [&] { return refused > 0; }))
        << "the queue of three never filled";
  }
  URC::TextToSpeech_cancelAll_Request cancel;
  cancel.set_details("the user said stop");
  URC::TextToSpeech_cancelAll_Reply cancelled_reply;
  ASSERT_EQ(call(*agent_, sink_, "cancelAll", cancel, cancelled_reply).status, call::Status::OK);
  int finished = 0, cancelled = 0;
  for (auto& c : calls) {
    const auto outcome = c.get();
    const std::string reason = not_ready_reason(outcome);
    if (outcome.status == call::Status::OK) {
      ++finished;
    } else if (reason.find("already waiting") == std::string::npos) {
      EXPECT_THAT(reason, ::testing::StartsWith("cancelled"));
      ++cancelled;
    }
  }
  std::printf("cancelAll: %d utterance(s) finished before it, %d cancelled, %d refused\n", finished, cancelled,
              refused);
  EXPECT_EQ(finished + cancelled + refused, 6);
  EXPECT_GE(cancelled, 1) << "cancelAll came while utterances waited";
  EXPECT_EQ(speak("stop").status, call::Status::OK);
}

TEST_F(TtsDevice, AnswersNotReadyOnceStopped) {
  agent_->stop();
  EXPECT_EQ(not_ready_reason(speak("hello")), "the text-to-speech device is stopping");
}

TEST(TtsDeviceConfig, RefusesAVoiceThatIsNotInstalled) {
  EXPECT_THAT(testing::config_error_of([] { make_tts_agent(YAML::Load("{voice: klingon}")); }),
              ::testing::HasSubstr("voice: no voice 'klingon'"));
}

}  // namespace
}  // namespace urs::devices
