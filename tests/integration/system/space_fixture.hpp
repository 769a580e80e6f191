#pragma once
// A CAMUS space made of real processes on loopback: urs-camus-server on an ephemeral port and a
// urs-sam hosting the diagnostic agent; `urs` runs the CLI against it.

#include <gtest/gtest.h>
#include <signal.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "metrics_scrape.hpp"
#include "process.hpp"

namespace urs::test {

class SpaceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = make_temp_dir("space");
    write(dir_ + "/token", "s3cret-token\n");
    write(dir_ + "/sam.yaml",
          "agents:\n"
          "  - name: diag\n"
          "    type: diagnostic\n"
          "    deadline_ms: 5000\n");
    start_server(0);
    ASSERT_TRUE(wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, std::chrono::seconds(10)))
        << server_->log();
    port_ = std::stoi(read_text(dir_ + "/port"));
    sam_ = std::make_unique<Process>(
        std::vector<std::string>{URS_SAM_BIN, "--space", "lab", "--server", server_address(), "--config",
                                 dir_ + "/sam.yaml", "--token-file", dir_ + "/token", "--log-level", "debug",
                                 "--metrics-listen", "127.0.0.1:0"},
        dir_ + "/sam.log");
    ASSERT_TRUE(wait_for_service("diag")) << sam_->log() << server_->log();
  }

  void TearDown() override {
    if (HasFailure()) {
      std::cerr << "---- server log\n"
                << (server_ ? server_->log() : "") << "---- sam log\n"
                << (sam_ ? sam_->log() : "");
    }
    sam_.reset();
    server_.reset();
    std::filesystem::remove_all(dir_);
  }

  void start_server(int port) {
    std::filesystem::remove(dir_ + "/port");
    server_ = std::make_unique<Process>(
        std::vector<std::string>{URS_SERVER_BIN, "--space", "lab", "--listen", "127.0.0.1:" + std::to_string(port),
                                 "--token-file", dir_ + "/token", "--token-role", "operator", "--data-dir",
                                 dir_ + "/data", "--port-file", dir_ + "/port", "--heartbeat-ms", "200",
                                 "--heartbeat-timeout-ms", "1000", "--log-level", "debug"},
        dir_ + "/server.log");
  }

  std::string server_address() const { return "127.0.0.1:" + std::to_string(port_); }

  // The port of the SAM's --metrics-listen endpoint (from its log).
  uint16_t sam_metrics_port() {
    EXPECT_TRUE(wait_until([&] { return metrics_port_in_log(sam_->log()).has_value(); }, std::chrono::seconds(10)));
    return metrics_port_in_log(sam_->log()).value_or(0);
  }

  CommandResult urs(std::vector<std::string> args, std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
    std::vector<std::string> argv{URS_CLI_BIN, "--server", server_address(), "--token-file", dir_ + "/token"};
    argv.insert(argv.end(), args.begin(), args.end());
    return run_command(argv, timeout);
  }

  bool wait_for_service(const std::string& name, std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    return wait_until(
        [&] {
          auto r = urs({"--timeout-ms", "500", "ls", name});
          return r.exit_code == 0 && r.out.find(name + " ") != std::string::npos;
        },
        timeout);
  }

  // `urs watch PATTERN`, exiting after `count` events (0: no limit) or `for_ms`; its output in watch.log.
  std::unique_ptr<Process> watch(const std::string& pattern, int count, int for_ms) {
    return std::make_unique<Process>(
        std::vector<std::string>{URS_CLI_BIN, "--server", server_address(), "--token-file", dir_ + "/token", "watch",
                                 pattern, "--count", std::to_string(count), "--for-ms", std::to_string(for_ms)},
        dir_ + "/watch.log");
  }

  static void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

  std::string dir_;
  int port_ = 0;
  std::unique_ptr<Process> server_;
  std::unique_ptr<Process> sam_;
};

}  // namespace urs::test
