#include "urs/devices/catalog.hpp"

#include "urs/camera/camera_agent.hpp"
#include "urs/devices/localizer.hpp"
#include "urs/devices/robot.hpp"
#include "urs/devices/tts.hpp"
#include "urs/devices/voice.hpp"

namespace urs::devices {

const std::map<std::string, DeviceType>& catalog() {
  static const std::map<std::string, DeviceType> devices = {
      {"robot", {make_robot_agent, "Robot"}},
      {"localizer", {make_localizer_agent, "Localizer"}},
      {"tts", {make_tts_agent, "TextToSpeech"}},
      {"voice", {make_voice_agent, "VoiceRecognition"}},
      {"camera", {camera::make_camera_agent, "Camera"}},
  };
  return devices;
}

}  // namespace urs::devices
