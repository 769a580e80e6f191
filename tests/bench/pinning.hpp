#pragma once
// urs-bench --pin: the client side on one CPU and every server on another, so that a call's
// wake-ups cross cores the same way on every path (this VM's timings are bimodal otherwise: a
// wake-up lands on an idle or a busy core). The bench pins itself (and so the client threads it
// starts) to kClientCpu; servers started as processes go through `taskset -c kServerCpu`, and the
// in-process servers' threads pin themselves with pin_server_thread().

#include <pthread.h>
#include <sched.h>

#include <string>
#include <vector>

namespace urs::bench {

inline constexpr int kClientCpu = 0;
inline constexpr int kServerCpu = 1;

inline bool& pinning() {
  static bool enabled = false;
  return enabled;
}

inline void pin_this_thread(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
}

// Called first by every server thread the bench runs itself.
inline void pin_server_thread() {
  if (pinning()) pin_this_thread(kServerCpu);
}

// The command line of a server process: under taskset when pinning.
inline std::vector<std::string> server_command(std::vector<std::string> argv) {
  if (pinning()) argv.insert(argv.begin(), {"/usr/bin/taskset", "-c", std::to_string(kServerCpu)});
  return argv;
}

}  // namespace urs::bench
