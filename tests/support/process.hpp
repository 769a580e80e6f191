#pragma once
// Real child processes for integration tests: spawn with arguments, capture output to a file,
// signal, wait with bounded timeouts. No fixed sleeps: wait_until polls a condition with a deadline.

#include <sys/types.h>

#include <chrono>
#include <functional>
#include <string>
#include <vector>

namespace urs::test {

class Process {
 public:
  // Starts `argv[0]` with the arguments; stdout and stderr go to `log_path` (appended).
  // Throws std::runtime_error if fork/exec fails.
  Process(std::vector<std::string> argv, std::string log_path);
  ~Process();  // SIGKILL if still running, then reaps
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;

  pid_t pid() const { return pid_; }
  bool running();
  void signal(int sig);
  // Waits for exit up to `timeout`; returns the exit code (128+signal if killed), or -1 on timeout.
  int wait(std::chrono::milliseconds timeout);
  void kill9();             // SIGKILL and reap
  std::string log() const;  // what the process printed so far

 private:
  pid_t pid_ = -1;
  int status_ = -1;
  std::string log_path_;
};

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

// Runs a command to completion (bounded by `timeout`, then SIGKILL) capturing stdout and stderr.
CommandResult run_command(const std::vector<std::string>& argv,
                          std::chrono::milliseconds timeout = std::chrono::seconds(30));

// Polls `condition` every few milliseconds until it holds or `timeout` passes.
bool wait_until(const std::function<bool()>& condition, std::chrono::milliseconds timeout);

// A fresh directory under $TMPDIR (or /tmp) named after the running test; removed by the caller.
std::string make_temp_dir(const std::string& prefix);

std::string read_text(const std::string& path);

// Resident memory of process `pid` in KiB (VmRSS of /proc/PID/status); -1 if it cannot be read.
long resident_kib(pid_t pid);

}  // namespace urs::test
