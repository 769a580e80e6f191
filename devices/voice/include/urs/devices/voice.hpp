#pragma once
// Voice-recognition device (interface URC::VoiceRecognition, idl/urc/VoiceRecognition.idl) on
// pocketsphinx with the US English acoustic model. One service agent, hosted by urs-sam or,
// through the generic RT hosting, by urs-rtc-manager.
//
// params (YAML map, every key optional):
//   mode: grammar           # grammar: only the phrases of `commands` (robot commands);
//                           # lm: free dictation with the model's full language model
//   commands: [go forward, turn left, ...]   # grammar mode; words must be in the dictionary
//   model_dir: <dir>        # holds en-us/ (acoustic model), en-us.lm.bin, cmudict-en-us.dict
//   decoders: 2             # recognitions and open streams served at once, 1..8
//   max_audio_s: 60         # longest audio accepted per recognition or stream
//   stream_idle_s: 60       # a stream not fed for this long is dropped when a decoder is needed
//   topic_prefix: voice     # events are published on "<topic_prefix>/recognized"

#include <yaml-cpp/yaml.h>

#include <memory>
#include <string>
#include <vector>

#include "urs/agent/agent.hpp"

namespace urs::devices {

enum class RecognitionMode { grammar, lm };

struct VoiceParams {
  RecognitionMode mode = RecognitionMode::grammar;
  std::vector<std::string> commands;  // defaults to default_robot_commands()
  std::string model_dir;              // defaults to the directory found at build time
  unsigned decoders = 2;
  double max_audio_s = 60;
  double stream_idle_s = 60;
  std::string topic_prefix = "voice";
};

// The command list used when `commands` is not given.
const std::vector<std::string>& default_robot_commands();

// Checks keys, types, ranges and the spelling of commands (not the model files). Commands are
// returned in lower case with single spaces. Throws urs::devices::ParamError naming each bad key.
VoiceParams parse_voice_params(const YAML::Node& params);

// Also loads the model (one decoder per `decoders`) and checks that every command word is in the
// dictionary. Throws urs::devices::ParamError naming the key (model_dir, commands).
std::shared_ptr<agent::ServiceAgent> make_voice_agent(const YAML::Node& params);

}  // namespace urs::devices
