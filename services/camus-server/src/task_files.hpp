#pragma once
// The task definitions of --tasks-dir: every *.yaml / *.yml file, named after its stem.

#include <string>
#include <vector>

#include "urs/camus_server/task_spec.hpp"

namespace urs::camus_server::tasks {

struct TaskFile {
  std::string path;
  std::string yaml;
  TaskSpec spec;
};

// The files of `dir` in name order, parsed. Throws util::ConfigError naming the directory or the
// file that cannot be read or does not parse.
std::vector<TaskFile> read_task_dir(const std::string& dir);

}  // namespace urs::camus_server::tasks
