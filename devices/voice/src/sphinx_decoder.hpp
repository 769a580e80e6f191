#pragma once
// One pocketsphinx decoder (acoustic model, dictionary and one search) recognising one
// utterance at a time from 16 kHz mono samples. Decoders are independent: several may run in
// different threads, each used by one thread at a time.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "urs/devices/voice.hpp"

struct ps_decoder_s;

namespace urs::devices {

constexpr uint32_t kDecoderRate = 16000;  // the rate of the en-us acoustic model

struct Hypothesis {
  std::string text;        // "" when nothing was recognised
  float confidence = 0.f;  // posterior probability of `text`, 0..1
};

class SphinxDecoder {
 public:
  // Loads the model of `model_dir`; in lm mode with its language model. std::runtime_error if
  // pocketsphinx refuses.
  SphinxDecoder(RecognitionMode mode, const std::string& model_dir);
  ~SphinxDecoder();
  SphinxDecoder(const SphinxDecoder&) = delete;
  SphinxDecoder& operator=(const SphinxDecoder&) = delete;

  // The words of `words` that the dictionary does not know.
  std::vector<std::string> unknown_words(const std::vector<std::string>& words);
  // Grammar mode: restricts recognition to the JSGF grammar. std::runtime_error if refused.
  void use_grammar(const std::string& jsgf);

  // An utterance: begin(), feed() any number of times, end(). begin() abandons an unfinished one.
  void begin();
  void feed(const int16_t* samples, std::size_t count);
  Hypothesis end();

 private:
  ps_decoder_s* ps_ = nullptr;
  bool in_utterance_ = false;
};

}  // namespace urs::devices
