#pragma once
// Text-to-speech device (interface URC::TextToSpeech, idl/urc/TextToSpeech.idl) on espeak-ng.
// One service agent, hosted by urs-sam or, through the generic RT hosting, by urs-rtc-manager.
//
// params (YAML map, every key optional):
//   voice: en-us            # initial voice, a name from getAvailableVoices()
//   rate: 175               # speaking rate in words per minute, 80..450
//   max_text_length: 1000   # bytes of UTF-8 accepted by speak()
//   max_queue: 16           # speak() calls waiting for the synthesiser before NotReady
//   topic_prefix: tts       # events are published on "<topic_prefix>/spoken"

#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <memory>
#include <string>

#include "urs/agent/agent.hpp"

namespace urs::devices {

struct TtsParams {
  std::string voice = "en-us";
  int rate = 175;
  std::size_t max_text_length = 1000;
  std::size_t max_queue = 16;
  std::string topic_prefix = "tts";
};

// Checks keys, types and ranges (not the voice, which needs the engine). Throws
// urs::devices::ParamError (urs/devices/params.hpp) listing each bad key.
TtsParams parse_tts_params(const YAML::Node& params);

// Also checks that `voice` is installed. Throws urs::devices::ParamError naming the key.
std::shared_ptr<agent::ServiceAgent> make_tts_agent(const YAML::Node& params);

}  // namespace urs::devices
