// urs-lab: the papers' experiments, run against a space as a user would (docs/experiments.md).
//
//   urs-lab square --via rt --naming H:P --port PATH:PORT --label rt-direct --out DIR
//   urs-lab square --via camus --server H:P --service robot1.navigation --label camus-bridge --out DIR
//   urs-lab speed --server H:P --service robot1.navigation --out DIR
//   urs-lab speech-vision --server H:P --camera camera --tts tts --voice voice --out DIR
//   urs-lab report --out DIR
//
// Exit codes: 0 done; 1 an experiment failed (a call, a leg that never ended); 2 bad usage.

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>

#include "ImageRecognition.pb.h"
#include "Navigation.pb.h"
#include "TextToSpeech.pb.h"
#include "VoiceRecognition.pb.h"
#include "experiments.hpp"
#include "navigation_stub.hpp"
#include "urs/planet/client.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/tls.hpp"

namespace {

using namespace std::chrono_literals;

struct Options {
  std::string out = "lab-out";
  std::string via = "camus";
  std::string server = "127.0.0.1:7600";
  std::string token_file;
  std::string naming = "127.0.0.1:2809";
  std::string service = "robot1.navigation";
  std::string port;
  std::string label;
  std::string trace = "dds";
  uint32_t domain = 0;
  std::string robot = "robot1";
  double speed = 500;
  double time_scale = 1;
  std::string camera = "camera";
  std::string tts = "tts";
  std::string voice = "voice";
  std::string text = "go forward";
  std::string log_level = "warn";
  urs::util::TlsConfig tls;
};

std::unique_ptr<urs::planet::Client> connect(const Options& o) {
  const auto endpoint = urs::util::parse_endpoint(o.server, "--server");
  urs::planet::ClientOptions options;
  options.host = endpoint.host;
  options.port = endpoint.port;
  const char* env_file = std::getenv("URS_TOKEN_FILE");
  options.token = urs::util::read_token_file(o.token_file.empty() && env_file ? env_file : o.token_file);
  options.peer_name = "urs-lab";
  options.tls = o.tls;
  urs::util::check_tls_client(options.tls);
  auto client = std::make_unique<urs::planet::Client>(options);
  client->start();
  if (!client->wait_connected(5s)) {
    throw std::runtime_error("cannot reach the CAMUS server " + o.server + ": " + client->last_error());
  }
  return client;
}

std::unique_ptr<urs::lab::Tracer> tracer(const Options& o, urs::lab::RemoteService& navigation) {
  if (o.trace == "poll") return std::make_unique<urs::lab::Tracer>(navigation, o.time_scale, 50ms);
  return std::make_unique<urs::lab::Tracer>(o.domain, o.robot, o.time_scale);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"urs-lab: the papers' experiments (square path, speed changes, speech and vision)"};
  Options o;
  app.add_option("--out", o.out, "Folder for the CSV, SVG, Markdown and JSON outputs")->capture_default_str();
  app.add_option("--log-level", o.log_level, urs::util::kLogLevels)->capture_default_str();
  auto camus_options = [&](CLI::App* command) {
    command->add_option("--server", o.server, "CAMUS server HOST:PORT")->capture_default_str();
    command->add_option("--token-file", o.token_file,
                        "File holding this client's credential token (or env URS_TOKEN_FILE)");
    urs::util::add_tls_client_flags(*command, o.tls);
  };
  auto motion_options = [&](CLI::App* command) {
    command->add_option("--service", o.service, "Navigation service on CAMUS")->capture_default_str();
    command->add_option("--trace", o.trace, "dds: the robot's ground truth; poll: getPosition")
        ->check(CLI::IsMember({"dds", "poll"}))
        ->capture_default_str();
    command->add_option("--domain", o.domain, "DDS domain of the robot's world state")->capture_default_str();
    command->add_option("--robot", o.robot, "The robot's name (DDS key)")->capture_default_str();
    command->add_option("--time-scale", o.time_scale, "The devices' simulated seconds per wall second")
        ->check(CLI::Range(0.01, 100.0))
        ->capture_default_str();
  };
  auto* square = app.add_subcommand("square", "Drive the square path and trace it");
  square
      ->add_option("--via", o.via,
                   "rt: CORBA straight to the RTC's port (omniORB stubs); camus: through the CAMUS server")
      ->check(CLI::IsMember({"rt", "camus"}))
      ->capture_default_str();
  square->add_option("--naming", o.naming, "Naming service HOST:PORT (--via rt)")->capture_default_str();
  square->add_option("--port", o.port, "PATH:PORT of the robot's Navigation provider (--via rt)");
  square->add_option("--label", o.label, "Name of this run in the report (default: --via)");
  square->add_option("--speed", o.speed, "Cruise speed, mm/s")->check(CLI::Range(1.0, 2000.0))->capture_default_str();
  camus_options(square);
  motion_options(square);
  auto* speed = app.add_subcommand("speed", "Change the speed 200 -> 800 -> 500 -> 0 mm/s while driving");
  camus_options(speed);
  motion_options(speed);
  auto* speech = app.add_subcommand("speech-vision", "Camera, image recognition, TTS and voice recognition");
  camus_options(speech);
  speech->add_option("--via", o.via, "camus: services by name through the CAMUS server; rt: provider ports PATH:PORT")
      ->check(CLI::IsMember({"rt", "camus"}))
      ->capture_default_str();
  speech->add_option("--naming", o.naming, "Naming service HOST:PORT (--via rt)")->capture_default_str();
  speech->add_option("--camera", o.camera, "ImageRecognition service or PATH:PORT (\"\": no camera)")
      ->capture_default_str();
  speech->add_option("--tts", o.tts, "TextToSpeech service or PATH:PORT")->capture_default_str();
  speech->add_option("--voice", o.voice, "VoiceRecognition service or PATH:PORT")->capture_default_str();
  speech->add_option("--text", o.text, "What the TTS says")->capture_default_str();
  auto* report = app.add_subcommand("report", "Combine the runs in --out into experiments.md and square.svg");
  app.require_subcommand(1);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }

  try {
    urs::util::init_logging("urs-lab", o.log_level);
    std::filesystem::create_directories(o.out);
    if (*report) {
      std::cout << urs::lab::write_report(o.out);
      return 0;
    }
    if (*speech) {
      std::unique_ptr<urs::planet::Client> client;
      std::unique_ptr<urs::rtc::Orb> orb;
      std::unique_ptr<urs::rtc::NamingClient> naming;
      // A service by name on CAMUS, or (--via rt) a provider port PATH:PORT of the interface.
      auto service = [&](const std::string& name, const google::protobuf::ServiceDescriptor& interface) {
        if (o.via == "rt") {
          if (!orb) {
            orb = std::make_unique<urs::rtc::Orb>();
            naming = std::make_unique<urs::rtc::NamingClient>(*orb, o.naming);
          }
          return urs::lab::rt_provider(*orb, *naming, name, interface);
        }
        if (!client) client = connect(o);
        return urs::lab::camus_service(*client, name);
      };
      auto camera =
          o.camera.empty()
              ? nullptr
              : service(o.camera, *URC::ImageRecognition_recognize_Request::descriptor()->file()->FindServiceByName(
                                      "ImageRecognition"));
      auto tts =
          service(o.tts, *URC::TextToSpeech_speak_Request::descriptor()->file()->FindServiceByName("TextToSpeech"));
      auto voice = service(o.voice, *URC::VoiceRecognition_playBytes_Request::descriptor()->file()->FindServiceByName(
                                        "VoiceRecognition"));
      const auto run = urs::lab::run_speech_vision(camera.get(), *tts, *voice, o.text);
      urs::lab::write_speech_vision(run, o.out);
      std::cout << "markers: " << run.markers.size() << ", heard \"" << run.heard << "\" for \"" << run.spoken
                << "\"\n";
      return 0;
    }
    std::unique_ptr<urs::planet::Client> client;
    std::unique_ptr<urs::rtc::Orb> orb;
    std::unique_ptr<urs::rtc::NamingClient> naming;
    std::unique_ptr<urs::lab::RemoteService> navigation;
    if (*square && o.via == "rt") {
      if (o.port.empty()) throw urs::util::ConfigError("--via rt needs --port PATH:PORT");
      orb = std::make_unique<urs::rtc::Orb>();
      naming = std::make_unique<urs::rtc::NamingClient>(*orb, o.naming);
      navigation = urs::lab::rt_navigation_stub(*orb, *naming, o.port);
    } else {
      client = connect(o);
      navigation = urs::lab::camus_service(*client, o.service);
    }
    auto trace = tracer(o, *navigation);
    if (*square) {
      const auto run =
          urs::lab::run_square(*navigation, *trace, o.speed, o.time_scale, o.label.empty() ? o.via : o.label);
      urs::lab::write_square(run, o.out);
      for (const auto& leg : run.legs) {
        std::cout << "(" << leg.target.x << ", " << leg.target.y << "): " << leg.error_mm << " mm, " << leg.time_s
                  << " s\n";
      }
    } else {
      const auto run = urs::lab::run_speed(*navigation, *trace, o.time_scale);
      urs::lab::write_speed(run, o.out);
      for (const auto& phase : run.phases) {
        std::cout << phase.command_mm_s << " mm/s commanded: " << phase.measured_mm_s << " mm/s measured\n";
      }
    }
    return 0;
  } catch (const urs::util::ConfigError& e) {
    std::cerr << "urs-lab: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "urs-lab: " << e.what() << "\n";
    return 1;
  }
}
