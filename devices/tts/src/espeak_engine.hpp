#pragma once
// The process's one espeak-ng synthesiser. espeak-ng keeps its state in globals, so every agent
// of the process shares this engine and synthesis runs under its lock, one utterance at a time.

#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace urs::devices {

struct EspeakVoice {
  std::string name;      // espeak-ng's language code of the voice, e.g. "en-us" (what setVoice takes)
  std::string language;  // BCP 47 spelling, e.g. "en-US"
  std::string gender;    // "male", "female" or ""
};

class EspeakEngine {
 public:
  // Initialises espeak-ng on first use; std::runtime_error if its data cannot be loaded.
  static EspeakEngine& instance();

  const std::vector<EspeakVoice>& voices() const { return voices_; }
  bool has_voice(const std::string& name) const;
  uint32_t sample_rate() const { return sample_rate_; }

  // Mono samples at sample_rate(). `keep_going` is polled between audio blocks: once it returns
  // false synthesis stops and the result is empty (nullopt). std::runtime_error on engine errors.
  std::optional<std::vector<int16_t>> synthesize(const std::string& text, const std::string& voice, int rate,
                                                 const std::function<bool()>& keep_going);

 private:
  EspeakEngine();
  std::mutex mutex_;
  uint32_t sample_rate_ = 0;
  std::vector<EspeakVoice> voices_;
};

}  // namespace urs::devices
