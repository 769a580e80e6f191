#include "sphinx_decoder.hpp"

#include <pocketsphinx.h>
#include <spdlog/spdlog.h>
#include <sphinxbase/ckd_alloc.h>
#include <sphinxbase/err.h>

#include <cstdarg>
#include <cstdio>
#include <mutex>
#include <stdexcept>

namespace urs::devices {

namespace {

constexpr const char* kGrammarSearch = "commands";
// Silence fed before and after every utterance. Audio that starts with speech (synthesised, or
// cut by a client's own voice detection) loses its first word otherwise: pocketsphinx's voice
// activity detection and noise estimate need some non-speech to settle on.
const std::vector<int16_t> kPadding(kDecoderRate / 2, 0);

// pocketsphinx logs every model detail to stderr; route it to the process log instead, where
// only its warnings and errors are visible at the default level.
void log_from_sphinx(void*, err_lvl_t level, const char* format, ...) {
  char text[1024];
  va_list args;
  va_start(args, format);
  std::vsnprintf(text, sizeof text, format, args);
  va_end(args);
  std::string line(text);
  while (!line.empty() && line.back() == '\n') line.pop_back();
  if (line.empty()) return;
  if (level >= ERR_ERROR) {
    spdlog::warn("pocketsphinx: {}", line);
  } else if (level == ERR_WARN) {
    spdlog::debug("pocketsphinx: {}", line);
  } else {
    spdlog::trace("pocketsphinx: {}", line);
  }
}

}  // namespace

SphinxDecoder::SphinxDecoder(RecognitionMode mode, const std::string& model_dir) {
  static std::once_flag logging;
  std::call_once(logging, [] {
    err_set_callback(log_from_sphinx, nullptr);
    err_set_logfp(nullptr);  // the configuration dump is written to this file, not through the callback
  });
  const std::string hmm = model_dir + "/en-us";
  const std::string dict = model_dir + "/cmudict-en-us.dict";
  const std::string lm = model_dir + "/en-us.lm.bin";
  cmd_ln_t* config = mode == RecognitionMode::lm
                         ? cmd_ln_init(nullptr, ps_args(), TRUE, "-hmm", hmm.c_str(), "-dict", dict.c_str(), "-lm",
                                       lm.c_str(), nullptr)
                         : cmd_ln_init(nullptr, ps_args(), TRUE, "-hmm", hmm.c_str(), "-dict", dict.c_str(), nullptr);
  if (config == nullptr) throw std::runtime_error("pocketsphinx refused its configuration");
  ps_ = ps_init(config);
  cmd_ln_free_r(config);  // the decoder keeps its own reference
  if (ps_ == nullptr) throw std::runtime_error("pocketsphinx cannot load the model in '" + model_dir + "'");
}

SphinxDecoder::~SphinxDecoder() {
  if (in_utterance_) ps_end_utt(ps_);
  ps_free(ps_);
}

std::vector<std::string> SphinxDecoder::unknown_words(const std::vector<std::string>& words) {
  std::vector<std::string> unknown;
  for (const auto& word : words) {
    char* pronunciation = ps_lookup_word(ps_, word.c_str());
    if (pronunciation == nullptr) {
      unknown.push_back(word);
    } else {
      ckd_free(pronunciation);
    }
  }
  return unknown;
}

void SphinxDecoder::use_grammar(const std::string& jsgf) {
  if (ps_set_jsgf_string(ps_, kGrammarSearch, jsgf.c_str()) != 0 || ps_set_search(ps_, kGrammarSearch) != 0) {
    throw std::runtime_error("pocketsphinx refused the command grammar");
  }
}

void SphinxDecoder::begin() {
  if (in_utterance_) ps_end_utt(ps_);
  in_utterance_ = false;
  if (ps_start_utt(ps_) != 0) throw std::runtime_error("pocketsphinx cannot start an utterance");
  in_utterance_ = true;
  feed(kPadding.data(), kPadding.size());
}

void SphinxDecoder::feed(const int16_t* samples, std::size_t count) {
  if (count == 0) return;
  if (ps_process_raw(ps_, samples, count, FALSE, FALSE) < 0) {
    throw std::runtime_error("pocketsphinx failed on the audio");
  }
}

Hypothesis SphinxDecoder::end() {
  feed(kPadding.data(), kPadding.size());
  in_utterance_ = false;
  if (ps_end_utt(ps_) != 0) throw std::runtime_error("pocketsphinx cannot end the utterance");
  Hypothesis result;
  int32 score = 0;
  const char* text = ps_get_hyp(ps_, &score);
  if (text == nullptr || *text == '\0') return result;
  result.text = text;
  // The posterior of the best path, in the decoder's log base.
  const double posterior = logmath_exp(ps_get_logmath(ps_), ps_get_prob(ps_));
  result.confidence = static_cast<float>(posterior < 0 ? 0 : posterior > 1 ? 1 : posterior);
  return result;
}

}  // namespace urs::devices
