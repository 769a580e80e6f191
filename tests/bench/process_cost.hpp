#pragma once
// What a path costs the processes it crosses, per call: CPU time and voluntary context switches
// (a thread blocking until it is woken: one per thread hand-off or wait for the network). Unlike
// a latency these do not depend on what else the machine runs, so they show a change in thread
// hand-offs even on a loaded machine. Read from /proc/<pid>/task/*/schedstat (nanoseconds on a
// CPU) and status (voluntary_ctxt_switches); threads that end meanwhile are not counted.

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace urs::bench {

struct ProcessCost {
  uint64_t cpu_ns = 0;
  uint64_t voluntary_switches = 0;
};

inline ProcessCost process_cost(pid_t pid) {
  ProcessCost cost;
  std::error_code error;
  for (const auto& task : std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/task", error)) {
    uint64_t on_cpu = 0;
    if (std::ifstream(task.path() / "schedstat") >> on_cpu) cost.cpu_ns += on_cpu;
    std::ifstream status(task.path() / "status");
    for (std::string line; std::getline(status, line);) {
      if (line.rfind("voluntary_ctxt_switches:", 0) == 0) {
        cost.voluntary_switches += std::stoull(line.substr(line.find(':') + 1));
        break;
      }
    }
  }
  return cost;
}

}  // namespace urs::bench
