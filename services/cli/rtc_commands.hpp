#pragma once
// `urs rtc ...`: browse and drive the RT-Components bound in a naming service (omniNames), in
// the spirit of rtshell. Only the standard interfaces (RTObject, PortService, ExecutionContext)
// are used, so OpenRTM-aist components are handled like URSLink's. See docs/rtc.md.
//
// Exit codes as for the rest of `urs`: 0 success; 1 an operation failed or a path or port does
// not exist; 2 bad usage; 3 the naming service cannot be reached.

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace urs::cli {

class RtcCommands {
 public:
  // Adds the `rtc` subcommand and its own subcommands to `app`.
  explicit RtcCommands(CLI::App& app);
  RtcCommands(const RtcCommands&) = delete;
  RtcCommands& operator=(const RtcCommands&) = delete;

  bool selected() const;
  // Runs the chosen command once `app` is parsed; returns the exit code.
  int run(const std::string& log_level);

 private:
  CLI::App* rtc_ = nullptr;
  CLI::App* ls_ = nullptr;
  CLI::App* cat_ = nullptr;
  CLI::App* act_ = nullptr;
  CLI::App* deact_ = nullptr;
  CLI::App* reset_ = nullptr;
  CLI::App* con_ = nullptr;
  CLI::App* dis_ = nullptr;
  CLI::App* call_ = nullptr;
  CLI::App* conf_ = nullptr;
  CLI::App* conf_ls_ = nullptr;
  CLI::App* conf_get_ = nullptr;
  CLI::App* conf_set_ = nullptr;
  CLI::App* conf_act_ = nullptr;

  std::string naming_;
  int call_timeout_ms_ = 2000;
  std::string path_;
  std::vector<std::string> paths_;
  bool long_ = false;
  std::string first_port_;
  std::string second_port_;
  std::vector<std::string> properties_;
  std::string connector_name_;
  std::string connector_id_;
  bool all_ = false;
  bool force_ = false;
  std::string operation_;
  std::string arguments_;
  std::string interface_;
  std::vector<std::string> idl_files_;
  int deadline_ms_ = 10000;
  bool show_trace_ = false;
  std::string parameter_;
  std::string value_;
  std::string set_;
};

}  // namespace urs::cli
