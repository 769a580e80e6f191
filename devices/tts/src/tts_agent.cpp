#include <spdlog/spdlog.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <future>
#include <mutex>
#include <thread>

#include "TextToSpeech.pb.h"
#include "espeak_engine.hpp"
#include "urs/agent/typed_agent.hpp"
#include "urs/audio/pcm.hpp"
#include "urs/devices/params.hpp"
#include "urs/devices/tts.hpp"
#include "urs/devices/urc_errors.hpp"
#include "urs/util/cli.hpp"

namespace urs::devices {

namespace {

using agent::CallContext;
using agent::Outcome;

constexpr uint32_t kOutputRate = 16000;  // the rate URC::TextToSpeech promises

// What the synthesis worker hands back to a waiting speak().
struct Synthesis {
  enum class End { done, cancelled, failed } end = End::done;
  std::vector<int16_t> samples;  // at the engine's rate
  std::string why;               // for cancelled and failed
};

class TtsAgent : public agent::TypedAgent {
 public:
  explicit TtsAgent(TtsParams params)
      : TypedAgent(*URC::TextToSpeech_speak_Request::descriptor()->file(), "TextToSpeech"),
        params_(std::move(params)),
        engine_(EspeakEngine::instance()),
        voice_(params_.voice) {
    on<URC::TextToSpeech_speak_Request, URC::TextToSpeech_speak_Reply>(
        "speak",
        [this](const auto& req, auto& rep, const CallContext&) { return speak(req.text(), *rep.mutable_result()); });
    on<URC::TextToSpeech_getAvailableVoices_Request, URC::TextToSpeech_getAvailableVoices_Reply>(
        "getAvailableVoices", [this](const auto&, auto& rep, const CallContext&) {
          for (const auto& v : engine_.voices()) {
            auto* voice = rep.add_result();
            voice->set_name(v.name);
            voice->set_language(v.language);
            voice->set_gender(v.gender);
          }
          return Outcome::ok();
        });
    on<URC::TextToSpeech_setVoice_Request, URC::TextToSpeech_setVoice_Reply>(
        "setVoice", [this](const auto& req, auto&, const CallContext&) {
          if (!engine_.has_voice(req.name())) {
            return invalid_argument("name", "no voice '" + req.name() + "' (see getAvailableVoices)");
          }
          std::lock_guard lock(mutex_);
          voice_ = req.name();
          return Outcome::ok();
        });
    on<URC::TextToSpeech_cancelAll_Request, URC::TextToSpeech_cancelAll_Reply>(
        "cancelAll", [this](const auto& req, auto&, const CallContext&) {
          cancel_all(req.details());
          return Outcome::ok();
        });
    on<URC::TextToSpeech__get_voice_Request, URC::TextToSpeech__get_voice_Reply>(
        "_get_voice", [this](const auto&, auto& rep, const CallContext&) {
          std::lock_guard lock(mutex_);
          rep.set_result(voice_);
          return Outcome::ok();
        });
    check_complete();
    worker_ = std::thread([this] { run(); });
  }

  ~TtsAgent() override { stop(); }

  void start(agent::EventSink& events) override {
    std::lock_guard lock(mutex_);
    events_ = &events;
  }

  void stop() override {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return;
      stopping_ = true;
      events_ = nullptr;
      answer_queued("the text-to-speech device is stopping");
    }
    wake_.notify_all();
    if (worker_.joinable()) worker_.join();
  }

 private:
  struct Job {
    std::string text;
    std::string voice;
    uint64_t generation;
    std::promise<Synthesis> done;
  };

  Outcome speak(const std::string& text, URC::AudioInfo& info) {
    if (text.find_first_not_of(" \t\r\n") == std::string::npos) {
      return invalid_argument("text", "is empty; give the words to speak");
    }
    if (text.size() > params_.max_text_length) {
      return invalid_argument("text", std::to_string(text.size()) + " bytes exceed the limit of " +
                                          std::to_string(params_.max_text_length));
    }
    std::future<Synthesis> result;
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return not_ready("the text-to-speech device is stopping");
      if (queue_.size() >= params_.max_queue) {
        return not_ready(std::to_string(queue_.size()) + " utterances are already waiting");
      }
      queue_.push_back(Job{text, voice_, generation_, {}});
      result = queue_.back().done.get_future();
    }
    wake_.notify_one();
    Synthesis synthesis = result.get();
    if (synthesis.end == Synthesis::End::cancelled) return not_ready("cancelled: " + synthesis.why);
    if (synthesis.end == Synthesis::End::failed) return Outcome::error(call::Status::INTERNAL, synthesis.why);

    audio::Pcm pcm{kOutputRate, 1, audio::resample(synthesis.samples, engine_.sample_rate(), kOutputRate)};
    info.set_sample_rate(pcm.sample_rate);
    info.set_channels(pcm.channels);
    info.set_bits_per_sample(16);
    info.set_duration(pcm.duration());
    info.set_wav(audio::encode_wav(pcm));
    publish_spoken(text);
    return Outcome::ok();
  }

  void publish_spoken(const std::string& text) {
    URC::TextToSpeech_speak_Request event;
    event.set_text(text);
    std::lock_guard lock(mutex_);
    if (events_ == nullptr) return;
    auto published = events_->publish(params_.topic_prefix + "/spoken", event);
    if (!published.ok())
      spdlog::warn("tts: event {}/spoken not published: {}", params_.topic_prefix, published.message);
  }

  void cancel_all(const std::string& details) {
    std::lock_guard lock(mutex_);
    spdlog::info("tts: cancelling {} waiting utterance(s){}: {}", queue_.size(),
                 busy_ ? " and the one in progress" : "", details);
    ++generation_;  // the utterance in progress sees it at its next audio block
    answer_queued(details);
  }

  // Caller holds mutex_.
  void answer_queued(const std::string& why) {
    for (auto& job : queue_) job.done.set_value(Synthesis{Synthesis::End::cancelled, {}, why});
    queue_.clear();
  }

  void run() {
    std::unique_lock lock(mutex_);
    while (true) {
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      Job job = std::move(queue_.front());
      queue_.pop_front();
      busy_ = true;
      lock.unlock();
      job.done.set_value(synthesize(job));
      lock.lock();
      busy_ = false;
    }
  }

  Synthesis synthesize(const Job& job) {
    const std::function<bool()> keep_going = [this, generation = job.generation] {
      return generation_.load() == generation && !stopping_.load();
    };
    try {
      auto samples = engine_.synthesize(job.text, job.voice, params_.rate, keep_going);
      if (!samples) return Synthesis{Synthesis::End::cancelled, {}, stopping_ ? "stopping" : "cancelAll"};
      return Synthesis{Synthesis::End::done, std::move(*samples), {}};
    } catch (const std::exception& e) {
      return Synthesis{Synthesis::End::failed, {}, e.what()};
    }
  }

  const TtsParams params_;
  EspeakEngine& engine_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::string voice_;
  std::deque<Job> queue_;
  std::atomic<uint64_t> generation_{0};
  std::atomic<bool> stopping_{false};
  bool busy_ = false;
  agent::EventSink* events_ = nullptr;
  std::thread worker_;
};

}  // namespace

TtsParams parse_tts_params(const YAML::Node& node) {
  TtsParams params;
  ParamReader p("tts", node, {"voice", "rate", "max_text_length", "max_queue", "topic_prefix"});
  params.voice = p.text("voice", params.voice);
  params.rate = p.integer("rate", params.rate, 80, 450);
  params.max_text_length = p.integer<std::size_t>("max_text_length", params.max_text_length, 1, 100000);
  params.max_queue = p.integer<std::size_t>("max_queue", params.max_queue, 1, 1024);
  params.topic_prefix = p.text("topic_prefix", params.topic_prefix);
  p.finish();
  return params;
}

std::shared_ptr<agent::ServiceAgent> make_tts_agent(const YAML::Node& node) {
  TtsParams params = parse_tts_params(node);
  if (!EspeakEngine::instance().has_voice(params.voice)) {
    throw ParamError("tts", {{"voice", "no voice '" + params.voice + "' installed in espeak-ng"}});
  }
  return std::make_shared<TtsAgent>(std::move(params));
}

}  // namespace urs::devices
