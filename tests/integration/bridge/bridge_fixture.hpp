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

class BridgeSpaceTest : public RtSpaceTest {
 protected:
  void SetUp() override {
    RtSpaceTest::SetUp();
    std::ofstream(dir_ + "/sam.yaml") << "agents:\n  - name: diag\n    type: diagnostic\n    deadline_ms: 5000\n";
    server_ = std::make_unique<Process>(
        std::vector<std::string>{URS_SERVER_BIN, "--space", "lab", "--listen", "127.0.0.1:0", "--data-dir",
                                 dir_ + "/data", "--port-file", dir_ + "/port", "--heartbeat-ms", "200",
                                 "--heartbeat-timeout-ms", "1000", "--log-level", "debug"},
        dir_ + "/server.log");
    ASSERT_TRUE(wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, std::chrono::seconds(10)))
        << server_->log();
    server_address_ = "127.0.0.1:" + read_text(dir_ + "/port");
    while (!server_address_.empty() && std::isspace(static_cast<unsigned char>(server_address_.back()))) {
      server_address_.pop_back();
    }
    sam_ = std::make_unique<Process>(std::vector<std::string>{URS_SAM_BIN, "--space", "lab", "--server",
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

  // Starts urs-bridge with `config_yaml` on naming context "bridgehost"; fails the test if it does
  // not bind its RTC.
  void start_bridge(const std::string& config_yaml) {
    std::ofstream(dir_ + "/bridge.yaml") << config_yaml;
    std::filesystem::remove(dir_ + "/bridge.ready");
    bridge_ = std::make_unique<Process>(
        std::vector<std::string>{URS_BRIDGE_BIN, "--space", "lab", "--server", server_address_, "--naming",
                                 naming_->address(), "--host", "bridgehost", "--config", dir_ + "/bridge.yaml",
                                 "--ready-file", dir_ + "/bridge.ready", "--log-level", "debug"},
        dir_ + "/bridge.log");
    ASSERT_TRUE(wait_until([&] { return std::filesystem::exists(dir_ + "/bridge.ready") || !bridge_->running(); },
                           std::chrono::seconds(20)));
    ASSERT_TRUE(std::filesystem::exists(dir_ + "/bridge.ready")) << bridge_->log();
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

  std::string server_address_;
  std::unique_ptr<Process> server_;
  std::unique_ptr<Process> sam_;
  std::unique_ptr<Process> bridge_;
  std::unique_ptr<planet::Client> planet_;  // the test's own Planet session
};

}  // namespace urs::test
