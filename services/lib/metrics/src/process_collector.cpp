#include "process_collector.hpp"

#include <dirent.h>
#include <sys/resource.h>
#include <unistd.h>

#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>

namespace urs::metrics::detail {
namespace {

prometheus::MetricFamily family(const char* name, const char* help, prometheus::MetricType type, double value) {
  prometheus::MetricFamily family;
  family.name = name;
  family.help = help;
  family.type = type;
  prometheus::ClientMetric metric;
  if (type == prometheus::MetricType::Counter) {
    metric.counter.value = value;
  } else {
    metric.gauge.value = value;
  }
  family.metric.push_back(metric);
  return family;
}

struct Stat {
  double cpu_seconds = 0;
  double threads = 0;
  double start_ticks = 0;
  double virtual_bytes = 0;
  double resident_pages = 0;
};

// /proc/self/stat (proc(5)): the fields after the command, whose name may hold spaces and ')'.
std::optional<Stat> read_stat() {
  std::ifstream in("/proc/self/stat");
  std::string line;
  if (!std::getline(in, line)) return std::nullopt;
  const auto close = line.rfind(')');
  if (close == std::string::npos) return std::nullopt;
  std::istringstream fields(line.substr(close + 2));
  std::vector<std::string> field;  // field[0] is (3) state
  for (std::string f; fields >> f;) field.push_back(f);
  if (field.size() < 22) return std::nullopt;
  const double ticks = static_cast<double>(sysconf(_SC_CLK_TCK));
  Stat stat;
  try {
    stat.cpu_seconds = (std::stod(field[11]) + std::stod(field[12])) / ticks;  // (14) utime + (15) stime
    stat.threads = std::stod(field[17]);                                       // (20) num_threads
    stat.start_ticks = std::stod(field[19]);                                   // (22) starttime
    stat.virtual_bytes = std::stod(field[20]);                                 // (23) vsize
    stat.resident_pages = std::stod(field[21]);                                // (24) rss
  } catch (const std::exception&) {
    return std::nullopt;
  }
  return stat;
}

// The boot time in seconds since the epoch (/proc/stat's btime).
std::optional<double> boot_time() {
  std::ifstream in("/proc/stat");
  for (std::string key; in >> key;) {
    if (key == "btime") {
      double value = 0;
      if (in >> value) return value;
      return std::nullopt;
    }
    in.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
  }
  return std::nullopt;
}

std::optional<double> open_descriptors() {
  DIR* dir = opendir("/proc/self/fd");
  if (dir == nullptr) return std::nullopt;
  double count = 0;
  while (const dirent* entry = readdir(dir)) {
    if (entry->d_name[0] != '.') ++count;
  }
  closedir(dir);
  return count - 1;  // less the descriptor reading the folder
}

}  // namespace

std::vector<prometheus::MetricFamily> ProcessCollector::Collect() const {
  using prometheus::MetricType;
  std::vector<prometheus::MetricFamily> families;
  if (auto stat = read_stat()) {
    families.push_back(family("process_cpu_seconds_total", "Total user and system CPU time spent in seconds.",
                              MetricType::Counter, stat->cpu_seconds));
    families.push_back(family("process_resident_memory_bytes", "Resident memory size in bytes.", MetricType::Gauge,
                              stat->resident_pages * static_cast<double>(sysconf(_SC_PAGESIZE))));
    families.push_back(family("process_virtual_memory_bytes", "Virtual memory size in bytes.", MetricType::Gauge,
                              stat->virtual_bytes));
    families.push_back(family("process_threads", "Threads of the process.", MetricType::Gauge, stat->threads));
    if (auto boot = boot_time()) {
      families.push_back(family("process_start_time_seconds", "Start time of the process since unix epoch in seconds.",
                                MetricType::Gauge,
                                *boot + stat->start_ticks / static_cast<double>(sysconf(_SC_CLK_TCK))));
    }
  }
  if (auto open = open_descriptors()) {
    families.push_back(family("process_open_fds", "Number of open file descriptors.", MetricType::Gauge, *open));
  }
  rlimit limit{};
  if (getrlimit(RLIMIT_NOFILE, &limit) == 0) {
    const double max = limit.rlim_cur == RLIM_INFINITY ? 0 : static_cast<double>(limit.rlim_cur);
    if (max > 0) {
      families.push_back(family("process_max_fds", "Maximum number of open file descriptors.", MetricType::Gauge, max));
    }
  }
  return families;
}

}  // namespace urs::metrics::detail
