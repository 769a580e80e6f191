#include "espeak_engine.hpp"

#include <espeak-ng/espeak_ng.h>

#include <cctype>
#include <set>
#include <stdexcept>

namespace urs::devices {

namespace {

struct Utterance {
  std::vector<int16_t>* samples;
  const std::function<bool()>* keep_going;
  bool aborted = false;
};

// espeak-ng hands each synthesised block to this callback; the utterance rides in user_data.
int on_audio(short* wav, int count, espeak_EVENT* events) {
  auto* utterance = static_cast<Utterance*>(events->user_data);
  if (utterance == nullptr) return 0;
  if (wav != nullptr && count > 0) utterance->samples->insert(utterance->samples->end(), wav, wav + count);
  if (!(*utterance->keep_going)()) {
    utterance->aborted = true;
    return 1;  // tells espeak-ng to stop this utterance
  }
  return 0;
}

std::string status_text(espeak_ng_STATUS status) {
  char text[512] = {};
  espeak_ng_GetStatusCodeMessage(status, text, sizeof text);
  return text;
}

// "en-gb-x-rp" -> "en-GB-x-rp": region subtags upper case, script subtags title case, private
// use (after "x") untouched.
std::string bcp47(const std::string& code) {
  std::string out;
  std::size_t start = 0;
  bool first = true;
  bool private_use = false;
  while (start <= code.size()) {
    std::size_t end = code.find('-', start);
    if (end == std::string::npos) end = code.size();
    std::string part = code.substr(start, end - start);
    if (!first && !private_use) {
      if (part == "x") {
        private_use = true;
      } else if (part.size() == 2) {
        for (auto& c : part) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      } else if (part.size() == 4) {
        part[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(part[0])));
      }
    }
    out += (first ? "" : "-") + part;
    first = false;
    start = end + 1;
  }
  return out;
}

}  // namespace

EspeakEngine& EspeakEngine::instance() {
  static EspeakEngine engine;
  return engine;
}

EspeakEngine::EspeakEngine() {
  espeak_ng_InitializePath(nullptr);
  espeak_ng_ERROR_CONTEXT context = nullptr;
  espeak_ng_STATUS status = espeak_ng_Initialize(&context);
  espeak_ng_ClearErrorContext(&context);
  if (status != ENS_OK) throw std::runtime_error("espeak-ng cannot start: " + status_text(status));
  status = espeak_ng_InitializeOutput(ENOUTPUT_MODE_SYNCHRONOUS, 0, nullptr);
  if (status != ENS_OK) throw std::runtime_error("espeak-ng output: " + status_text(status));
  espeak_SetSynthCallback(on_audio);
  sample_rate_ = static_cast<uint32_t>(espeak_ng_GetSampleRate());

  std::set<std::string> seen;
  for (const espeak_VOICE** v = espeak_ListVoices(nullptr); v != nullptr && *v != nullptr; ++v) {
    // languages: a priority byte, then a NUL-terminated code; the first is the voice's own.
    const char* languages = (*v)->languages;
    if (languages == nullptr || languages[0] == '\0') continue;
    const std::string code = languages + 1;
    if (code.empty() || !seen.insert(code).second) continue;
    const char* gender = (*v)->gender == ENGENDER_MALE ? "male" : (*v)->gender == ENGENDER_FEMALE ? "female" : "";
    voices_.push_back({code, bcp47(code), gender});
  }
}

bool EspeakEngine::has_voice(const std::string& name) const {
  for (const auto& v : voices_) {
    if (v.name == name) return true;
  }
  return false;
}

std::optional<std::vector<int16_t>> EspeakEngine::synthesize(const std::string& text, const std::string& voice,
                                                             int rate, const std::function<bool()>& keep_going) {
  std::lock_guard lock(mutex_);
  espeak_ng_STATUS status = espeak_ng_SetVoiceByName(voice.c_str());
  if (status != ENS_OK) throw std::runtime_error("espeak-ng voice '" + voice + "': " + status_text(status));
  status = espeak_ng_SetParameter(espeakRATE, rate, 0);
  if (status != ENS_OK) throw std::runtime_error("espeak-ng rate: " + status_text(status));
  std::vector<int16_t> samples;
  Utterance utterance{&samples, &keep_going};
  status =
      espeak_ng_Synthesize(text.c_str(), text.size() + 1, 0, POS_CHARACTER, 0, espeakCHARS_UTF8, nullptr, &utterance);
  if (utterance.aborted) {
    espeak_ng_Cancel();  // drops what the aborted utterance left in the engine
    return std::nullopt;
  }
  if (status != ENS_OK) throw std::runtime_error("espeak-ng synthesis: " + status_text(status));
  return samples;
}

}  // namespace urs::devices
