#pragma once
// A space holding both middlewares as real processes on loopback: omniNames and urs-rtc-manager
// (RtSpaceTest), urs-camus-server, a urs-sam hosting the diagnostic agent as "diag", and urs-bridge
// started from a YAML text. The test process has a Planet client of the space.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "rt_space.hpp"
#include "urs/planet/client.hpp"

namespace urs::test {

// A bridge configuration offering every Diagnostic provider's port as CAMUS service
// "rt.<instance>", each call bounded by `deadline_ms` (also the service's advertised deadline).
inline std::string diagnostic_rules(int deadline_ms) {
  return "name: bridge-test\n"
         "rt_to_camus:\n"
         "  poll_ms: 100\n"
         "  providers:\n"
         "    - match: \"*/Diagnostic*.rtc\"\n"
         "      interface: URS::Diagnostic\n"
         "      name: \"rt.{instance}\"\n"
         "      deadline_ms: " + std::to_string(deadline_ms) + "\n";
}

// What a Planet client sees of one call.
struct Observed {
  planet::Status status = planet::INTERNAL;
  std::string payload;
  std::string exception_type;
  std::string message;
};

class BridgeSpaceTest : public RtSpaceTest {
 protected:
  void SetUp() override {
    RtSpaceTest::SetUp();
    std::ofstream(dir_ + "/sam.yaml") << "agents:\n  - name: diag\n    type: diagnostic\n    deadline_ms: 5000\n";
    server_ = std::make_unique<Process>(
        std::vector<std::string>{URS_SERVER_BIN, "--space", space_, "--listen", "127.0.0.1:0", "--data-dir",
                                 dir_ + "/data", "--port-file", dir_ + "/port", "--heartbeat-ms", "200",
                                 "--heartbeat-timeout-ms", "1000", "--log-level", "debug"},
        dir_ + "/server.log");
    ASSERT_TRUE(wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, std::chrono::seconds(10)))
        << server_->log();
    server_address_ = "127.0.0.1:" + read_text(dir_ + "/port");
    while (!server_address_.empty() && std::isspace(static_cast<unsigned char>(server_address_.back()))) {
      server_address_.pop_back();
    }
    sam_ = std::make_unique<Process>(std::vector<std::string>{URS_SAM_BIN, "--space", space_, "--server",
                                                              server_address_, "--config", dir_ + "/sam.yaml",
                                                              "--log-level", "debug"},
                                     dir_ + "/sam.log");
    planet::ClientOptions options;
    const auto colon = server_address_.rfind(':');
    options.port = static_cast<uint16_t>(std::stoi(server_address_.substr(colon + 1)));
    options.peer_name = "tester";
    planet_ = std::make_unique<planet::Client>(options);
    planet_->start();
    ASSERT_TRUE(planet_->wait_connected(std::chrono::seconds(5))) << planet_->last_error();
    ASSERT_TRUE(wait_for_service("diag")) << sam_->log();
  }

  void TearDown() override {
    if (HasFailure()) {
      std::cerr << "---- bridge log\n" << (bridge_ ? bridge_->log() : "") << "---- server log\n"
                << (server_ ? server_->log() : "") << "---- sam log\n" << (sam_ ? sam_->log() : "");
    }
    bridge_.reset();
    planet_.reset();
    sam_.reset();
    server_.reset();
    RtSpaceTest::TearDown();
  }

  // Starts urs-bridge with `config_yaml` on naming context "bridgehost", linked to this space's
  // CAMUS server and naming service; fails the test if it does not come up.
  void start_bridge(const std::string& config_yaml) {
    bridge_ = launch_bridge("bridge", config_yaml,
                            {"--server", server_address_, "--naming", naming_->address(), "--host", "bridgehost"});
  }

  // Starts a urs-bridge named `name` (files <dir>/<name>.*) with `sides` (its --server and/or
  // --naming arguments) and waits for its ready file. A `wrapper` (a command that ends by exec'ing
  // its arguments) runs it.
  std::unique_ptr<Process> launch_bridge(const std::string& name, const std::string& config_yaml,
                                         const std::vector<std::string>& sides, const std::string& space = "",
                                         std::vector<std::string> wrapper = {}) {
    const std::string config = dir_ + "/" + name + ".yaml";
    const std::string ready = dir_ + "/" + name + ".ready";
    std::ofstream(config) << config_yaml;
    std::filesystem::remove(ready);
    std::vector<std::string> argv = std::move(wrapper);
    argv.insert(argv.end(), {URS_BRIDGE_BIN, "--space", space.empty() ? space_ : space, "--config", config,
                             "--ready-file", ready, "--log-level", "debug"});
    argv.insert(argv.end(), sides.begin(), sides.end());
    auto process = std::make_unique<Process>(argv, dir_ + "/" + name + ".log");
    const bool up = wait_until([&] { return std::filesystem::exists(ready) || !process->running(); },
                               std::chrono::seconds(20));
    EXPECT_TRUE(up && std::filesystem::exists(ready)) << name << " did not come up:\n" << process->log();
    return process;
  }

  CommandResult urs(std::vector<std::string> args, std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
    std::vector<std::string> argv{URS_CLI_BIN, "--server", server_address_};
    argv.insert(argv.end(), args.begin(), args.end());
    return run_command(argv, timeout);
  }

  // The registry's line for `name` from `urs ls`, "" if it is not listed.
  std::string listed(const std::string& name) {
    const auto r = urs({"--timeout-ms", "1000", "ls", name});
    std::istringstream lines(r.out);
    for (std::string line; std::getline(lines, line);) {
      if (line.compare(0, name.size() + 1, name + " ") == 0) return line;
    }
    return "";
  }
  bool wait_for_service(const std::string& name, std::chrono::milliseconds timeout = std::chrono::seconds(15)) {
    return wait_until([&] { return !listed(name).empty(); }, timeout);
  }
  bool wait_service_gone(const std::string& name, std::chrono::milliseconds timeout = std::chrono::seconds(15)) {
    return wait_until([&] { return listed(name).empty(); }, timeout);
  }
  bool bound(const std::string& path) {
    CORBA::Object_var object = client_->try_resolve(path);
    return !CORBA::is_nil(object);
  }

  std::string space_ = "lab";  // the CAMUS space's name; set before SetUp() to change it
  std::string server_address_;
  std::unique_ptr<Process> server_;
  std::unique_ptr<Process> sam_;
  std::unique_ptr<Process> bridge_;
  std::unique_ptr<planet::Client> planet_;  // the test's own Planet session
};

}  // namespace urs::test
