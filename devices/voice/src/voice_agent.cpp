#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>

#include "VoiceRecognition.pb.h"
#include "sphinx_decoder.hpp"
#include "urs/agent/typed_agent.hpp"
#include "urs/audio/pcm.hpp"
#include "urs/devices/params.hpp"
#include "urs/devices/urc_errors.hpp"
#include "urs/devices/voice.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::devices {

namespace {

using agent::CallContext;
using agent::Outcome;
using Clock = std::chrono::steady_clock;

// Audio is decoded in blocks of this many samples (100 ms) so that cancelAll() is seen quickly.
constexpr std::size_t kBlock = kDecoderRate / 10;
// A call waits at most this long for a free decoder (less if its deadline is nearer).
constexpr auto kDecoderWait = std::chrono::seconds(5);

// Decoders not in use. Leases give them back on destruction, even after the agent has gone.
class DecoderPool : public std::enable_shared_from_this<DecoderPool> {
 public:
  class Lease {
   public:
    Lease(std::shared_ptr<DecoderPool> pool, std::unique_ptr<SphinxDecoder> decoder)
        : pool_(std::move(pool)), decoder_(std::move(decoder)) {}
    ~Lease() { pool_->give_back(std::move(decoder_)); }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    SphinxDecoder& decoder() { return *decoder_; }

   private:
    std::shared_ptr<DecoderPool> pool_;
    std::unique_ptr<SphinxDecoder> decoder_;
  };

  void add(std::unique_ptr<SphinxDecoder> decoder) { give_back(std::move(decoder)); }

  // nullptr if none became free before `until`.
  std::unique_ptr<Lease> take(Clock::time_point until) {
    std::unique_lock lock(mutex_);
    if (!freed_.wait_until(lock, until, [this] { return !free_.empty(); })) return nullptr;
    auto decoder = std::move(free_.back());
    free_.pop_back();
    return std::make_unique<Lease>(shared_from_this(), std::move(decoder));
  }

 private:
  void give_back(std::unique_ptr<SphinxDecoder> decoder) {
    {
      std::lock_guard lock(mutex_);
      free_.push_back(std::move(decoder));
    }
    freed_.notify_one();
  }

  std::mutex mutex_;
  std::condition_variable freed_;
  std::vector<std::unique_ptr<SphinxDecoder>> free_;
};

struct Stream {
  std::mutex mutex;  // one feed or finish at a time
  uint32_t sample_rate = 0;
  uint16_t channels = 0;
  std::unique_ptr<DecoderPool::Lease> lease;
  std::vector<int16_t> held;  // mono audio of a stream not at the decoder's rate, resampled at the end
  std::size_t frames = 0;     // received so far, at the stream's rate
  Clock::time_point last_fed;
  std::atomic<bool> cancelled{false};
};

URC::RecognitionResult to_result(const Hypothesis& hypothesis) {
  URC::RecognitionResult result;
  result.set_text(hypothesis.text);
  result.set_confidence(hypothesis.confidence);
  const auto now = std::chrono::system_clock::now().time_since_epoch();
  const auto sec = std::chrono::duration_cast<std::chrono::seconds>(now);
  result.mutable_stamp()->set_sec(sec.count());
  result.mutable_stamp()->set_nsec(
      static_cast<uint32_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(now - sec).count()));
  return result;
}

std::string grammar_of(const std::vector<std::string>& commands) {
  std::string jsgf = "#JSGF V1.0;\ngrammar robot;\npublic <command> = ";
  for (std::size_t i = 0; i < commands.size(); ++i) jsgf += (i == 0 ? "" : " | ") + commands[i];
  return jsgf + ";\n";
}

std::vector<std::string> words_of(const std::vector<std::string>& commands) {
  std::set<std::string> words;
  for (const auto& command : commands) {
    std::istringstream in(command);
    for (std::string w; in >> w;) words.insert(w);
  }
  return {words.begin(), words.end()};
}

class VoiceAgent : public agent::TypedAgent {
 public:
  VoiceAgent(VoiceParams params, std::shared_ptr<DecoderPool> pool)
      : TypedAgent(*URC::VoiceRecognition_playBytes_Request::descriptor()->file(), "VoiceRecognition"),
        params_(std::move(params)),
        pool_(std::move(pool)) {
    on<URC::VoiceRecognition_playBytes_Request, URC::VoiceRecognition_playBytes_Reply>(
        "playBytes", [this](const auto& req, auto& rep, const CallContext& ctx) {
          return recognize_wav(req.wave(), "wave", ctx, *rep.mutable_result());
        });
    on<URC::VoiceRecognition_playFile_Request, URC::VoiceRecognition_playFile_Reply>(
        "playFile", [this](const auto& req, auto& rep, const CallContext& ctx) {
          std::string bytes;
          if (auto refused = read_file(req.path(), bytes)) return *refused;
          return recognize_wav(bytes, "path", ctx, *rep.mutable_result());
        });
    on<URC::VoiceRecognition_startStream_Request, URC::VoiceRecognition_startStream_Reply>(
        "startStream",
        [this](const auto& req, auto& rep, const CallContext& ctx) { return start_stream(req.format(), ctx, rep); });
    on<URC::VoiceRecognition_feedStream_Request, URC::VoiceRecognition_feedStream_Reply>(
        "feedStream",
        [this](const auto& req, auto&, const CallContext&) { return feed_stream(req.stream(), req.pcm()); });
    on<URC::VoiceRecognition_finishStream_Request, URC::VoiceRecognition_finishStream_Reply>(
        "finishStream", [this](const auto& req, auto& rep, const CallContext&) {
          return finish_stream(req.stream(), *rep.mutable_result());
        });
    on<URC::VoiceRecognition_cancelAll_Request, URC::VoiceRecognition_cancelAll_Reply>(
        "cancelAll", [this](const auto& req, auto&, const CallContext&) {
          cancel_all(req.details());
          return Outcome::ok();
        });
    check_complete();
  }

  ~VoiceAgent() override { stop(); }

  void start(agent::EventSink& events) override {
    std::lock_guard lock(mutex_);
    events_ = &events;
  }

  void stop() override {
    {
      std::lock_guard lock(mutex_);
      events_ = nullptr;
    }
    cancel_all("the voice-recognition device is stopping");
  }

 private:
  using Results = google::protobuf::RepeatedPtrField<URC::RecognitionResult>;

  std::optional<Outcome> read_file(const std::string& path, std::string& bytes) const {
    std::ifstream in(path, std::ios::binary);
    if (!in) return invalid_argument("path", "cannot read '" + path + "' on the device's host");
    // The largest WAV max_audio_s can accept: stereo at 96 kHz, plus room for metadata chunks.
    const double limit = params_.max_audio_s * 96000 * 2 * 2 + (1 << 20);
    std::ostringstream content;
    content << in.rdbuf();
    bytes = content.str();
    if (static_cast<double>(bytes.size()) > limit) {
      return invalid_argument("path", "'" + path + "' is larger than max_audio_s allows");
    }
    return std::nullopt;
  }

  Outcome recognize_wav(const std::string& bytes, const std::string& parameter, const CallContext& ctx,
                        Results& results) {
    audio::Pcm pcm;
    try {
      pcm = audio::decode_wav(bytes);
    } catch (const audio::FormatError& e) {
      return invalid_argument(parameter, e.what());
    }
    if (pcm.duration() > params_.max_audio_s) {
      return invalid_argument(parameter, "holds " + std::to_string(pcm.duration()) + " s of audio, more than " +
                                             std::to_string(params_.max_audio_s) + " s");
    }
    const uint64_t generation = generation_.load();
    const auto samples = audio::to_mono(pcm, kDecoderRate);
    auto lease = take_decoder(ctx);
    if (!lease) return not_ready("all " + std::to_string(params_.decoders) + " decoders are busy");
    SphinxDecoder& decoder = lease->decoder();
    decoder.begin();
    for (std::size_t at = 0; at < samples.size(); at += kBlock) {
      if (generation_.load() != generation) return not_ready("cancelled");
      decoder.feed(samples.data() + at, std::min(kBlock, samples.size() - at));
    }
    return deliver(decoder.end(), results);
  }

  Outcome start_stream(const URC::AudioFormat& format, const CallContext& ctx,
                       URC::VoiceRecognition_startStream_Reply& reply) {
    if (format.sample_rate() < 8000 || format.sample_rate() > 96000) {
      return invalid_argument("format", "sample_rate " + std::to_string(format.sample_rate()) +
                                            " Hz is outside 8000..96000 (16000 is decoded as it arrives)");
    }
    if (format.channels() < 1 || format.channels() > 2) {
      return invalid_argument("format", "channels " + std::to_string(format.channels()) + " is not 1 or 2");
    }
    auto stream = std::make_shared<Stream>();
    stream->sample_rate = format.sample_rate();
    stream->channels = static_cast<uint16_t>(format.channels());
    stream->lease = take_decoder(ctx);
    if (!stream->lease) {
      return not_ready("all " + std::to_string(params_.decoders) + " decoders are busy with recognitions or streams");
    }
    if (stream->sample_rate == kDecoderRate) stream->lease->decoder().begin();
    stream->last_fed = Clock::now();
    std::lock_guard lock(mutex_);
    const uint32_t id = ++last_stream_id_;
    streams_[id] = std::move(stream);
    reply.set_result(id);
    return Outcome::ok();
  }

  Outcome feed_stream(uint32_t id, const std::string& pcm) {
    auto stream = find_stream(id);
    if (!stream) return no_stream(id);
    std::lock_guard lock(stream->mutex);
    if (stream->cancelled) return no_stream(id);
    std::vector<int16_t> samples;
    try {
      samples = audio::samples_from_bytes(pcm);
    } catch (const audio::FormatError& e) {
      return invalid_argument("pcm", e.what());
    }
    if (samples.size() % stream->channels != 0) {
      return invalid_argument(
          "pcm", "holds a partial frame: " + std::to_string(stream->channels) + " interleaved samples make a frame");
    }
    const std::size_t frames = samples.size() / stream->channels;
    if (static_cast<double>(stream->frames + frames) / stream->sample_rate > params_.max_audio_s) {
      return invalid_argument("pcm",
                              "the stream would exceed max_audio_s (" + std::to_string(params_.max_audio_s) + " s)");
    }
    stream->frames += frames;
    stream->last_fed = Clock::now();
    samples = audio::downmix(samples, stream->channels);
    if (stream->sample_rate != kDecoderRate) {
      stream->held.insert(stream->held.end(), samples.begin(), samples.end());
    } else {
      stream->lease->decoder().feed(samples.data(), samples.size());
    }
    return Outcome::ok();
  }

  Outcome finish_stream(uint32_t id, Results& results) {
    std::shared_ptr<Stream> stream;
    {
      std::lock_guard lock(mutex_);
      auto it = streams_.find(id);
      if (it == streams_.end()) return no_stream(id);
      stream = std::move(it->second);
      streams_.erase(it);
    }
    std::lock_guard lock(stream->mutex);
    if (stream->cancelled) return no_stream(id);
    SphinxDecoder& decoder = stream->lease->decoder();
    if (stream->sample_rate != kDecoderRate) {
      const auto samples = audio::resample(stream->held, stream->sample_rate, kDecoderRate);
      decoder.begin();
      decoder.feed(samples.data(), samples.size());
    }
    return deliver(decoder.end(), results);
  }

  void cancel_all(const std::string& details) {
    std::map<uint32_t, std::shared_ptr<Stream>> dropped;
    {
      std::lock_guard lock(mutex_);
      ++generation_;
      dropped.swap(streams_);
    }
    for (auto& entry : dropped) entry.second->cancelled = true;
    spdlog::log(dropped.empty() ? spdlog::level::debug : spdlog::level::info,
                "voice: cancelling recognitions in progress and {} open stream(s): {}", dropped.size(), details);
  }

  std::unique_ptr<DecoderPool::Lease> take_decoder(const CallContext& ctx) {
    if (auto lease = pool_->take(Clock::now())) return lease;
    drop_idle_streams();
    return pool_->take(std::min(ctx.deadline, Clock::now() + kDecoderWait));
  }

  void drop_idle_streams() {
    const auto idle = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(params_.stream_idle_s));
    std::vector<std::shared_ptr<Stream>> dropped;
    {
      std::lock_guard lock(mutex_);
      for (auto it = streams_.begin(); it != streams_.end();) {
        std::unique_lock stream_lock(it->second->mutex, std::try_to_lock);  // a busy stream is not idle
        if (stream_lock.owns_lock() && Clock::now() - it->second->last_fed > idle) {
          spdlog::info("voice: dropping stream {}, idle for more than {} s", it->first, params_.stream_idle_s);
          it->second->cancelled = true;
          stream_lock.unlock();
          dropped.push_back(std::move(it->second));
          it = streams_.erase(it);
        } else {
          ++it;
        }
      }
    }
  }

  std::shared_ptr<Stream> find_stream(uint32_t id) {
    std::lock_guard lock(mutex_);
    auto it = streams_.find(id);
    return it == streams_.end() ? nullptr : it->second;
  }

  static Outcome no_stream(uint32_t id) {
    return invalid_argument("stream", "no open stream " + std::to_string(id) +
                                          " (never started, finished, cancelled or dropped when idle)");
  }

  Outcome deliver(const Hypothesis& hypothesis, Results& results) {
    *results.Add() = to_result(hypothesis);
    std::lock_guard lock(mutex_);
    if (events_ != nullptr) {
      auto published = events_->publish(params_.topic_prefix + "/recognized", results.Get(0));
      if (!published.ok())
        spdlog::warn("voice: event {}/recognized not published: {}", params_.topic_prefix, published.message);
    }
    return Outcome::ok();
  }

  const VoiceParams params_;
  std::shared_ptr<DecoderPool> pool_;
  std::mutex mutex_;
  std::map<uint32_t, std::shared_ptr<Stream>> streams_;
  uint32_t last_stream_id_ = 0;
  std::atomic<uint64_t> generation_{0};
  agent::EventSink* events_ = nullptr;
};

}  // namespace

const std::vector<std::string>& default_robot_commands() {
  static const std::vector<std::string> commands{"go forward",
                                                 "go back",
                                                 "turn left",
                                                 "turn right",
                                                 "stop",
                                                 "go to the kitchen",
                                                 "go to the living room",
                                                 "come here",
                                                 "speak louder",
                                                 "speak softer",
                                                 "what time is it",
                                                 "follow me"};
  return commands;
}

VoiceParams parse_voice_params(const YAML::Node& node) {
  VoiceParams params;
  params.commands = default_robot_commands();
  params.model_dir = URS_POCKETSPHINX_MODEL_DIR;
  ParamReader p("voice", node,
                {"mode", "commands", "model_dir", "decoders", "max_audio_s", "stream_idle_s", "topic_prefix"});
  if (p.choice("mode", "grammar", {"grammar", "lm"}) == "lm") params.mode = RecognitionMode::lm;
  if (p.has("commands")) {
    std::vector<std::string> normalised;
    for (const auto& command : p.text_list("commands", {})) {
      std::istringstream in(command);
      std::string phrase;
      for (std::string word; in >> word;) {
        std::transform(word.begin(), word.end(), word.begin(),
                       [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        if (word.find_first_not_of("abcdefghijklmnopqrstuvwxyz'") != std::string::npos) {
          p.fail("commands", "'" + command + "' has a word other than letters and apostrophes");
        }
        phrase += (phrase.empty() ? "" : " ") + word;
      }
      if (phrase.empty()) p.fail("commands", "'" + command + "' has no word");
      if (std::find(normalised.begin(), normalised.end(), phrase) == normalised.end()) normalised.push_back(phrase);
    }
    if (!normalised.empty()) params.commands = std::move(normalised);
  }
  params.model_dir = p.text("model_dir", params.model_dir);
  params.decoders = p.integer("decoders", params.decoders, 1u, 8u);
  params.max_audio_s = p.number("max_audio_s", params.max_audio_s, 1, 600);
  params.stream_idle_s = p.number("stream_idle_s", params.stream_idle_s, 1, 3600);
  params.topic_prefix = p.text("topic_prefix", params.topic_prefix);
  p.finish();
  return params;
}

std::shared_ptr<agent::ServiceAgent> make_voice_agent(const YAML::Node& node) {
  VoiceParams params = parse_voice_params(node);
  auto pool = std::make_shared<DecoderPool>();
  const std::string jsgf = grammar_of(params.commands);
  for (unsigned i = 0; i < params.decoders; ++i) {
    std::unique_ptr<SphinxDecoder> decoder;
    try {
      decoder = std::make_unique<SphinxDecoder>(params.mode, params.model_dir);
    } catch (const std::runtime_error& e) {
      throw ParamError("voice", {{"model_dir", e.what()}});
    }
    if (params.mode == RecognitionMode::grammar) {
      const auto unknown = decoder->unknown_words(words_of(params.commands));
      if (!unknown.empty()) {
        throw ParamError("voice",
                         {{"commands", "words not in the dictionary: " +
                                           util::join(std::set<std::string>(unknown.begin(), unknown.end()))}});
      }
      decoder->use_grammar(jsgf);
    }
    pool->add(std::move(decoder));
  }
  return std::make_shared<VoiceAgent>(std::move(params), std::move(pool));
}

}  // namespace urs::devices
