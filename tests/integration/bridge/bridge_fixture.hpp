#pragma once
// A space holding both middlewares as real processes on loopback: omniNames and urs-rtc-manager
// (RtSpaceTest), urs-camus-server, a urs-sam hosting the diagnostic agent as "diag", and urs-bridge
// started from a YAML text. The test process has a Planet client of the space. With named
// credentials (credentials_), the server admits only those and "space-admin" (an operator), whose
// token the fixture's own clients present: the SAM, the bridges, the test's client and the CLI.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
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
         "      deadline_ms: " +
         std::to_string(deadline_ms) + "\n";
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
    std::vector<std::string> server_argv{URS_SERVER_BIN, "--space",        space_,         "--listen",
                                         "127.0.0.1:0",  "--data-dir",     dir_ + "/data", "--port-file",
                                         dir_ + "/port", "--heartbeat-ms", "200",          "--heartbeat-timeout-ms",
                                         "1000",         "--log-level",    "debug"};
    const std::vector<std::string> credentials = credentials_args();
    server_argv.insert(server_argv.end(), credentials.begin(), credentials.end());
    server_ = std::make_unique<Process>(server_argv, dir_ + "/server.log");
    ASSERT_TRUE(wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, std::chrono::seconds(10)))
        << server_->log();
    server_address_ = "127.0.0.1:" + read_text(dir_ + "/port");
    while (!server_address_.empty() && std::isspace(static_cast<unsigned char>(server_address_.back()))) {
      server_address_.pop_back();
    }
    std::vector<std::string> sam_argv{URS_SAM_BIN, "--space",          space_,        "--server", server_address_,
                                      "--config",  dir_ + "/sam.yaml", "--log-level", "debug"};
    const std::vector<std::string> token = admin_token_args();
    sam_argv.insert(sam_argv.end(), token.begin(), token.end());
    sam_ = std::make_unique<Process>(sam_argv, dir_ + "/sam.log");
    planet_ = connect_client("tester", credentials_.empty() ? "" : kAdmin);
    ASSERT_TRUE(planet_->wait_connected(std::chrono::seconds(5))) << planet_->last_error();
    ASSERT_TRUE(wait_for_service("diag")) << sam_->log();
  }

  // The credential the fixture's own clients present when the server has named credentials.
  static constexpr const char* kAdmin = "space-admin";
  // The server's --credentials: credentials_ and kAdmin (an operator), each token in
  // "<dir>/<name>.token"; none without credentials_.
  std::vector<std::string> credentials_args() {
    if (credentials_.empty()) return {};
    std::string yaml = "credentials:\n";
    std::vector<std::pair<std::string, std::string>> all = credentials_;
    all.emplace_back(kAdmin, "operator");
    for (const auto& [name, role] : all) {
      std::ofstream(token_file(name)) << token(name) << "\n";
      yaml += "  - {name: " + name + ", role: " + role + ", token_file: " + name + ".token}\n";
    }
    std::ofstream(dir_ + "/credentials.yaml") << yaml;
    return {"--credentials", dir_ + "/credentials.yaml"};
  }
  std::string token_file(const std::string& name) const { return dir_ + "/" + name + ".token"; }
  static std::string token(const std::string& name) { return name + "-token-" + std::to_string(::getpid()); }
  // --token-file of kAdmin when the server has named credentials.
  std::vector<std::string> admin_token_args() const {
    if (credentials_.empty()) return {};
    return {"--token-file", token_file(kAdmin)};
  }
  // A started Planet client of the space presenting `credential`'s token (none if empty).
  std::unique_ptr<planet::Client> connect_client(const std::string& peer, const std::string& credential = "") {
    planet::ClientOptions options;
    const auto colon = server_address_.rfind(':');
    options.port = static_cast<uint16_t>(std::stoi(server_address_.substr(colon + 1)));
    options.peer_name = peer;
    if (!credential.empty()) options.token = token(credential);
    auto client = std::make_unique<planet::Client>(options);
    client->start();
    return client;
  }

  void TearDown() override {
    if (HasFailure()) {
      std::cerr << "---- bridge log\n"
                << (bridge_ ? bridge_->log() : "") << "---- server log\n"
                << (server_ ? server_->log() : "") << "---- sam log\n"
                << (sam_ ? sam_->log() : "");
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
    if (std::find(sides.begin(), sides.end(), "--server") != sides.end()) {
      const std::vector<std::string> token = admin_token_args();
      argv.insert(argv.end(), token.begin(), token.end());
    }
    auto process = std::make_unique<Process>(argv, dir_ + "/" + name + ".log");
    const bool up =
        wait_until([&] { return std::filesystem::exists(ready) || !process->running(); }, std::chrono::seconds(20));
    EXPECT_TRUE(up && std::filesystem::exists(ready)) << name << " did not come up:\n" << process->log();
    return process;
  }

  CommandResult urs(std::vector<std::string> args, std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
    std::vector<std::string> argv{URS_CLI_BIN, "--server", server_address_};
    const std::vector<std::string> token = admin_token_args();
    argv.insert(argv.end(), token.begin(), token.end());
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
  // Named credentials of the server (name, role), set before SetUp(); none: every peer anonymous.
  std::vector<std::pair<std::string, std::string>> credentials_;
  std::string server_address_;
  std::unique_ptr<Process> server_;
  std::unique_ptr<Process> sam_;
  std::unique_ptr<Process> bridge_;
  std::unique_ptr<planet::Client> planet_;  // the test's own Planet session
};

}  // namespace urs::test
