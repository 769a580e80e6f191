#pragma once
// The papers' experiments, run by a client against a Navigation, TextToSpeech, VoiceRecognition
// and ImageRecognition service wherever they are (remote_service.hpp), with the robot's path
// traced from the shared world state (DDS ground truth) or by polling getPosition.

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "remote_service.hpp"

namespace urs::world {
class World;
}

namespace urs::lab {

struct Sample {
  double t = 0;  // s of simulated time since the tracer's first sample
  double x = 0;  // m
  double y = 0;  // m
};

// Records where the robot is, on the robot's simulated clock.
class Tracer {
 public:
  // The robot's ground truth on DDS topic urs/world/pose (the devices' world state). Each sample
  // is stamped with the simulated time it carries (PoseSample::sim_time), so the trace and the
  // speeds measured from it do not depend on how late the samples arrive (a loaded machine).
  Tracer(uint32_t domain, const std::string& robot, double time_scale);
  // getPosition of `navigation` every `period` (when DDS does not reach the robot's space). The
  // reply carries no time: samples are stamped with the wall clock times `time_scale`, which
  // is the robot's clock only while the machine keeps up.
  Tracer(RemoteService& navigation, double time_scale, std::chrono::milliseconds period);
  ~Tracer();
  Tracer(const Tracer&) = delete;
  Tracer& operator=(const Tracer&) = delete;

  std::vector<Sample> samples() const;
  std::optional<Sample> latest() const;
  // The robot's simulated seconds since the tracer's first sample, as far as the tracer knows:
  // the newest sample's time (DDS), or the scaled wall clock (getPosition).
  double now() const;
  // Waits until a sample at `t` or later is traced (false if none is within `wall_timeout`).
  bool wait_until(double t, std::chrono::steady_clock::duration wall_timeout) const;
  const std::string& source() const { return source_; }

 private:
  void add(double x, double y, double t);

  const double time_scale_;
  const std::chrono::steady_clock::time_point start_;
  const bool simulated_clock_;  // samples carry the robot's simulated time
  std::string source_;
  mutable std::mutex mutex_;
  mutable std::condition_variable added_;
  std::optional<double> origin_;  // sim_time of the first sample
  std::vector<Sample> samples_;
  std::unique_ptr<world::World> world_;
  bool stop_ = false;
  std::thread poller_;
};

// Speed over a sliding window of `window` simulated seconds: (middle of the window, mm/s).
std::vector<std::pair<double, double>> speed_profile(const std::vector<Sample>& trace, double window = 0.2);

struct Waypoint {
  double x = 0;
  double y = 0;
};

// The papers' rectangle: (1.5,1) -> (1.5,3) -> (5,3) -> (5,1) -> (1.5,1), metres.
std::vector<Waypoint> square_path();

struct Leg {
  Waypoint target;
  double error_mm = 0;  // distance of the robot (traced) to the target when it reported arrival
  double time_s = 0;    // simulated seconds from moveTo to arrival
};

struct SquareRun {
  std::string label;
  std::string path;  // how the calls travelled
  double speed_mm_s = 0;
  std::vector<Leg> legs;
  std::vector<Sample> trace;
};

// Drives the square at `speed_mm_s`: setSpeed, then per waypoint moveTo and _get_state polled
// until ARRIVED. Throws std::runtime_error on a failed call or a leg that does not end.
SquareRun run_square(RemoteService& navigation, Tracer& tracer, double speed_mm_s, double time_scale,
                     const std::string& label);

struct SpeedPhase {
  double command_mm_s = 0;
  double duration_s = 0;     // simulated
  double measured_mm_s = 0;  // median speed over the last 40 % of the phase
};

struct SpeedRun {
  std::string path;
  std::vector<SpeedPhase> phases;
  std::vector<Sample> trace;
  std::vector<std::pair<double, double>> speed;    // (t, mm/s) from the trace
  std::vector<std::pair<double, double>> command;  // (t, mm/s) as commanded
};

// 200 -> 800 -> 500 -> 0 mm/s while driving east, each for a set simulated time.
SpeedRun run_speed(RemoteService& navigation, Tracer& tracer, double time_scale);

struct SpeechVisionRun {
  std::string path;
  uint32_t width = 0, height = 0;
  std::size_t png_bytes = 0;
  std::vector<std::string> markers;  // contents, most confident first
  std::string spoken;
  double audio_s = 0;
  std::string heard;
  double confidence = 0;
};

// The second paper's scenario: open the camera, capture an image, recognise markers (skipped
// without a camera), speak `text`, recognise the speech.
SpeechVisionRun run_speech_vision(RemoteService* camera, RemoteService& tts, RemoteService& voice,
                                  const std::string& text);

// Reports: CSV, SVG, Markdown, JSON.
void write_square(const SquareRun& run, const std::string& dir);
void write_speed(const SpeedRun& run, const std::string& dir);
void write_speech_vision(const SpeechVisionRun& run, const std::string& dir);
// Combines the square runs found in `dir` (square-*.csv / .json) into square.svg and
// experiments.md (with the speed and speech-vision results if present). Returns the Markdown.
std::string write_report(const std::string& dir);

}  // namespace urs::lab
