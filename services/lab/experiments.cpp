#include "experiments.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>
#include <stdexcept>

#include "ImageRecognition.pb.h"
#include "Navigation.pb.h"
#include "TextToSpeech.pb.h"
#include "VoiceRecognition.pb.h"
#include "plot.hpp"
#include "urs/world/world.hpp"

namespace urs::lab {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

namespace {

constexpr auto kCallDeadline = 10s;
const char* const kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"};

std::string fixed(double value, int decimals) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(decimals) << value;
  return out.str();
}

std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

template <typename Request, typename Reply>
Reply call(RemoteService& service, const std::string& operation, const Request& request) {
  Reply reply;
  expect_ok(service.call(operation, request, reply, kCallDeadline), service.where() + "." + operation);
  return reply;
}

URC::NavigationState state_of(RemoteService& navigation) {
  return call<URC::Navigation__get_state_Request, URC::Navigation__get_state_Reply>(navigation, "_get_state", {})
      .result();
}

void set_speed(RemoteService& navigation, double mm_s) {
  URC::Navigation_setSpeed_Request request;
  request.set_speed(static_cast<uint32_t>(mm_s));
  call<URC::Navigation_setSpeed_Request, URC::Navigation_setSpeed_Reply>(navigation, "setSpeed", request);
}

void move_to(RemoteService& navigation, const Waypoint& target) {
  URC::Navigation_moveTo_Request request;
  request.set_x(target.x);
  request.set_y(target.y);
  call<URC::Navigation_moveTo_Request, URC::Navigation_moveTo_Reply>(navigation, "moveTo", request);
}

std::vector<std::pair<double, double>> xy(const std::vector<Sample>& trace) {
  std::vector<std::pair<double, double>> points;
  for (const auto& s : trace) points.emplace_back(s.x, s.y);
  return points;
}

void write_trace_csv(const std::vector<Sample>& trace, const std::string& path) {
  std::ostringstream csv;
  csv << "t_s,x_m,y_m\n";
  for (const auto& s : trace) csv << fixed(s.t, 3) << "," << fixed(s.x, 4) << "," << fixed(s.y, 4) << "\n";
  write_text(path, csv.str());
}

std::vector<Sample> read_trace_csv(const std::string& path) {
  std::ifstream in(path);
  std::vector<Sample> trace;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    Sample s;
    char comma = 0;
    std::istringstream fields(line);
    if (fields >> s.t >> comma >> s.x >> comma >> s.y) trace.push_back(s);
  }
  return trace;
}

}  // namespace

// ---- tracer ----------------------------------------------------------------------------------

Tracer::Tracer(uint32_t domain, const std::string& robot, double time_scale)
    : time_scale_(time_scale),
      start_(Clock::now()),
      simulated_clock_(true),
      source_("ground truth on DDS topic urs/world/pose") {
  world_ = std::make_unique<world::World>(domain, "urs-lab");
  world_->subscribe(world::Channel::ground_truth, robot,
                    [this](const world::PoseSample& pose) { add(pose.x, pose.y, pose.sim_time); });
  // DDS discovery usually takes milliseconds but can take seconds: start once the robot is seen.
  std::unique_lock lock(mutex_);
  if (!added_.wait_for(lock, 15s, [this] { return !samples_.empty(); })) {
    lock.unlock();
    world_.reset();
    throw std::runtime_error("no pose of robot '" + robot + "' on DDS domain " + std::to_string(domain) +
                             " within 15 s (is the robot running, in that domain?)");
  }
}

Tracer::Tracer(RemoteService& navigation, double time_scale, std::chrono::milliseconds period)
    : time_scale_(time_scale),
      start_(Clock::now()),
      simulated_clock_(false),
      source_("getPosition polled through " + navigation.where()) {
  poller_ = std::thread([this, &navigation, period] {
    while (true) {
      {
        std::lock_guard lock(mutex_);
        if (stop_) return;
      }
      URC::Navigation_getPosition_Reply reply;
      const auto asked = Clock::now();
      if (navigation.call("getPosition", URC::Navigation_getPosition_Request(), reply, 2s).ok()) {
        add(reply.result().x(), reply.result().y(),
            std::chrono::duration<double>(asked - start_).count() * time_scale_);
      }
      std::this_thread::sleep_until(asked + period);
    }
  });
}

Tracer::~Tracer() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  if (poller_.joinable()) poller_.join();
  world_.reset();
}

void Tracer::add(double x, double y, double t) {
  {
    std::lock_guard lock(mutex_);
    if (!origin_) origin_ = t;
    t -= *origin_;
    if (!samples_.empty() && t <= samples_.back().t) return;  // sent again (a late joiner's history)
    samples_.push_back({t, x, y});
  }
  added_.notify_all();
}

std::vector<Sample> Tracer::samples() const {
  std::lock_guard lock(mutex_);
  return samples_;
}

std::optional<Sample> Tracer::latest() const {
  std::lock_guard lock(mutex_);
  if (samples_.empty()) return std::nullopt;
  return samples_.back();
}

double Tracer::now() const {
  if (!simulated_clock_) return std::chrono::duration<double>(Clock::now() - start_).count() * time_scale_;
  std::lock_guard lock(mutex_);
  return samples_.empty() ? 0 : samples_.back().t;
}

bool Tracer::wait_until(double t, Clock::duration wall_timeout) const {
  std::unique_lock lock(mutex_);
  return added_.wait_for(lock, wall_timeout, [&] { return !samples_.empty() && samples_.back().t >= t; });
}

std::vector<std::pair<double, double>> speed_profile(const std::vector<Sample>& trace, double window) {
  std::vector<std::pair<double, double>> speed;
  for (std::size_t i = 1, j = 0; i < trace.size(); ++i) {
    while (j + 1 < i && trace[i].t - trace[j + 1].t >= window) ++j;
    const double dt = trace[i].t - trace[j].t;
    if (dt < window / 4) continue;
    const double d = std::hypot(trace[i].x - trace[j].x, trace[i].y - trace[j].y);
    speed.emplace_back(trace[i].t - dt / 2, d / dt * 1000.0);
  }
  return speed;
}

// ---- square path -----------------------------------------------------------------------------

std::vector<Waypoint> square_path() { return {{1.5, 1.0}, {1.5, 3.0}, {5.0, 3.0}, {5.0, 1.0}, {1.5, 1.0}}; }

SquareRun run_square(RemoteService& navigation, Tracer& tracer, double speed_mm_s, double time_scale,
                     const std::string& label) {
  SquareRun run;
  run.label = label;
  run.path = navigation.where();
  run.speed_mm_s = speed_mm_s;
  const double t0 = tracer.now();
  set_speed(navigation, speed_mm_s);
  for (const Waypoint& target : square_path()) {
    const double started = tracer.now();
    move_to(navigation, target);
    const auto give_up = Clock::now() + std::chrono::duration<double>(120.0 / time_scale) + 5s;
    while (state_of(navigation) != URC::NAVIGATION_STATE_ARRIVED) {
      if (Clock::now() > give_up) {
        throw std::runtime_error("the robot did not reach (" + fixed(target.x, 2) + ", " + fixed(target.y, 2) +
                                 ") within 120 s of simulated time");
      }
      std::this_thread::sleep_for(10ms);
    }
    Leg leg;
    leg.target = target;
    // Where the robot was when it reported arrival: the first position traced after the one
    // known when the report was read (the robot writes its pose after it changed its state).
    const double reported = tracer.now();
    tracer.wait_until(std::nextafter(reported, reported + 1), 2s);
    leg.time_s = reported - started;
    const auto at = tracer.latest();
    if (!at) throw std::runtime_error("no position traced (" + tracer.source() + ")");
    leg.error_mm = std::hypot(at->x - target.x, at->y - target.y) * 1000.0;
    run.legs.push_back(leg);
  }
  for (const auto& s : tracer.samples()) {
    if (s.t >= t0) run.trace.push_back({s.t - t0, s.x, s.y});
  }
  return run;
}

// ---- speed changes ---------------------------------------------------------------------------

SpeedRun run_speed(RemoteService& navigation, Tracer& tracer, double time_scale) {
  SpeedRun run;
  run.path = navigation.where();
  run.phases = {{200, 3.0}, {800, 2.0}, {500, 2.0}, {0, 1.5}};
  const double t0 = tracer.now();
  std::vector<double> phase_start;
  set_speed(navigation, run.phases.front().command_mm_s);
  move_to(navigation, {6.0, tracer.latest() ? tracer.latest()->y : 1.0});
  for (std::size_t i = 0; i < run.phases.size(); ++i) {
    if (i > 0) set_speed(navigation, run.phases[i].command_mm_s);
    phase_start.push_back(tracer.now() - t0);
    // Held for its simulated duration on the robot's clock, however late its ticks run.
    const double until = phase_start.back() + t0 + run.phases[i].duration_s;
    if (!tracer.wait_until(until, std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(run.phases[i].duration_s / time_scale)) +
                                      30s)) {
      throw std::runtime_error("the robot's clock stood still: no pose traced for 30 s (" + tracer.source() + ")");
    }
  }
  phase_start.push_back(tracer.now() - t0);
  call<URC::Navigation_stop_Request, URC::Navigation_stop_Reply>(navigation, "stop", {});
  for (const auto& s : tracer.samples()) {
    if (s.t >= t0) run.trace.push_back({s.t - t0, s.x, s.y});
  }
  run.speed = speed_profile(run.trace, 0.2);
  for (std::size_t i = 0; i < run.phases.size(); ++i) {
    run.command.emplace_back(phase_start[i], run.phases[i].command_mm_s);
    run.command.emplace_back(phase_start[i + 1], run.phases[i].command_mm_s);
    const double from = phase_start[i] + 0.6 * (phase_start[i + 1] - phase_start[i]);
    std::vector<double> settled;
    for (const auto& [t, v] : run.speed) {
      if (t >= from && t <= phase_start[i + 1]) settled.push_back(v);
    }
    if (!settled.empty()) {
      std::nth_element(settled.begin(), settled.begin() + settled.size() / 2, settled.end());
      run.phases[i].measured_mm_s = settled[settled.size() / 2];
    }
  }
  return run;
}

// ---- speech and vision -----------------------------------------------------------------------

SpeechVisionRun run_speech_vision(RemoteService* camera, RemoteService& tts, RemoteService& voice,
                                  const std::string& text) {
  SpeechVisionRun run;
  run.path = (camera ? camera->where() + ", " : "") + tts.where() + ", " + voice.where();
  if (camera) {
    URC::ImageRecognition_openCamera_Request open;
    open.set_device(0);
    call<URC::ImageRecognition_openCamera_Request, URC::ImageRecognition_openCamera_Reply>(*camera, "openCamera", open);
    URC::ImageRecognition_captureImage_Request capture;
    capture.set_encoding(URC::IMAGE_ENCODING_PNG);
    const auto image = call<URC::ImageRecognition_captureImage_Request, URC::ImageRecognition_captureImage_Reply>(
        *camera, "captureImage", capture);
    run.width = image.result().format().width();
    run.height = image.result().format().height();
    run.png_bytes = image.result().data().size();
    const auto markers =
        call<URC::ImageRecognition_recognize_Request, URC::ImageRecognition_recognize_Reply>(*camera, "recognize", {});
    for (const auto& marker : markers.result()) run.markers.push_back(marker.content());
  }

  URC::TextToSpeech_speak_Request speak;
  speak.set_text(text);
  const auto audio = call<URC::TextToSpeech_speak_Request, URC::TextToSpeech_speak_Reply>(tts, "speak", speak);
  run.spoken = text;
  run.audio_s = audio.result().duration();
  URC::VoiceRecognition_playBytes_Request play;
  play.set_wave(audio.result().wav());
  const auto heard =
      call<URC::VoiceRecognition_playBytes_Request, URC::VoiceRecognition_playBytes_Reply>(voice, "playBytes", play);
  if (heard.result_size() > 0) {
    run.heard = heard.result(0).text();
    run.confidence = heard.result(0).confidence();
  }
  return run;
}

// ---- reports ---------------------------------------------------------------------------------

void write_square(const SquareRun& run, const std::string& dir) {
  write_trace_csv(run.trace, dir + "/square-" + run.label + ".csv");
  std::ostringstream md;
  md << "| " << run.label << " | " << run.path << " |";
  double worst = 0, total = 0;
  std::ostringstream json;
  json << "{\"label\":" << json_string(run.label) << ",\"path\":" << json_string(run.path)
       << ",\"speed_mm_s\":" << run.speed_mm_s << ",\"legs\":[";
  for (std::size_t i = 0; i < run.legs.size(); ++i) {
    const Leg& leg = run.legs[i];
    md << " " << fixed(leg.error_mm, 1) << " mm / " << fixed(leg.time_s, 2) << " s |";
    worst = std::max(worst, leg.error_mm);
    total += leg.time_s;
    json << (i ? "," : "") << "{\"x\":" << leg.target.x << ",\"y\":" << leg.target.y
         << ",\"error_mm\":" << fixed(leg.error_mm, 2) << ",\"time_s\":" << fixed(leg.time_s, 3) << "}";
  }
  md << " " << fixed(worst, 1) << " mm | " << fixed(total, 1) << " s |\n";
  json << "],\"worst_error_mm\":" << fixed(worst, 2) << ",\"total_time_s\":" << fixed(total, 3) << "}\n";
  write_text(dir + "/square-" + run.label + ".md", md.str());
  write_text(dir + "/square-" + run.label + ".json", json.str());
}

void write_speed(const SpeedRun& run, const std::string& dir) {
  std::ostringstream csv;
  csv << "t_s,speed_mm_s\n";
  for (const auto& [t, v] : run.speed) csv << fixed(t, 3) << "," << fixed(v, 1) << "\n";
  write_text(dir + "/speed.csv", csv.str());
  Figure figure{"Speed changes 200 → 800 → 500 → 0 mm/s (" + run.path + ")",
                "time (s, simulated)",
                "speed (mm/s)",
                {{"commanded", "#888888", run.command, true, false}, {"measured", kColors[0], run.speed, false, false}},
                false};
  write_text(dir + "/speed.svg", to_svg(figure));
  std::ostringstream md, json;
  md << "| commanded (mm/s) | held for (s) | measured, settled (mm/s) |\n|---|---|---|\n";
  json << "{\"path\":" << json_string(run.path) << ",\"phases\":[";
  for (std::size_t i = 0; i < run.phases.size(); ++i) {
    const auto& p = run.phases[i];
    md << "| " << p.command_mm_s << " | " << fixed(p.duration_s, 1) << " | " << fixed(p.measured_mm_s, 1) << " |\n";
    json << (i ? "," : "") << "{\"command_mm_s\":" << p.command_mm_s << ",\"duration_s\":" << p.duration_s
         << ",\"measured_mm_s\":" << fixed(p.measured_mm_s, 2) << "}";
  }
  json << "]}\n";
  write_text(dir + "/speed.md", md.str());
  write_text(dir + "/speed.json", json.str());
}

void write_speech_vision(const SpeechVisionRun& run, const std::string& dir) {
  std::ostringstream md, json, markers;
  for (std::size_t i = 0; i < run.markers.size(); ++i) markers << (i ? ", " : "") << run.markers[i];
  md << "Calls: " << run.path << ".\n\n| step | result |\n|---|---|\n";
  if (run.width > 0) {
    md << "| openCamera(0), captureImage(PNG) | " << run.width << " × " << run.height << ", " << run.png_bytes
       << " bytes |\n"
       << "| recognize() | " << (run.markers.empty() ? "no marker" : markers.str()) << " |\n";
  }
  md << "| speak(\"" << run.spoken << "\") | " << fixed(run.audio_s, 2) << " s of audio |\n"
     << "| playBytes(that audio) | \"" << run.heard << "\" (confidence " << fixed(run.confidence, 2) << ") |\n";
  json << "{\"path\":" << json_string(run.path) << ",\"width\":" << run.width << ",\"height\":" << run.height
       << ",\"png_bytes\":" << run.png_bytes << ",\"markers\":[";
  for (std::size_t i = 0; i < run.markers.size(); ++i) json << (i ? "," : "") << json_string(run.markers[i]);
  json << "],\"spoken\":" << json_string(run.spoken) << ",\"audio_s\":" << fixed(run.audio_s, 3)
       << ",\"heard\":" << json_string(run.heard) << ",\"confidence\":" << fixed(run.confidence, 3) << "}\n";
  write_text(dir + "/speech-vision.md", md.str());
  write_text(dir + "/speech-vision.json", json.str());
}

std::string write_report(const std::string& dir) {
  namespace fs = std::filesystem;
  std::vector<std::string> labels;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("square-", 0) == 0 && entry.path().extension() == ".md") {
      labels.push_back(name.substr(7, name.size() - 10));
    }
  }
  std::sort(labels.begin(), labels.end());
  std::vector<std::pair<double, double>> ideal;
  for (const auto& w : square_path()) ideal.emplace_back(w.x, w.y);
  Figure figure{"Square path at 500 mm/s: the robot's traces", "x (m)", "y (m)", {}, true};
  figure.series.push_back({"commanded path", "#888888", ideal, true, false});
  for (std::size_t i = 0; i < labels.size(); ++i) {
    figure.series.push_back(
        {labels[i], kColors[i % 5], xy(read_trace_csv(dir + "/square-" + labels[i] + ".csv")), false, false});
  }
  figure.series.push_back({"waypoints", "#000000", ideal, false, true});
  write_text(dir + "/square.svg", to_svg(figure));

  std::ostringstream md;
  auto read = [&](const std::string& name) {
    std::ifstream in(dir + "/" + name);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  };
  md << "## Square path\n\n![square path](square.svg)\n\n"
     << "Error = distance of the robot (traced) to the waypoint when it reported arrival; time = simulated seconds "
        "from moveTo to arrival.\n\n"
     << "| run | calls | (1.5, 1) | (1.5, 3) | (5, 3) | (5, 1) | (1.5, 1) | worst | total |\n"
     << "|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& label : labels) md << read("square-" + label + ".md");
  if (fs::exists(dir + "/speed.md")) md << "\n## Speed changes\n\n![speed profile](speed.svg)\n\n" << read("speed.md");
  if (fs::exists(dir + "/speech-vision.md")) md << "\n## Speech and vision\n\n" << read("speech-vision.md");
  write_text(dir + "/experiments.md", md.str());
  return md.str();
}

}  // namespace urs::lab
