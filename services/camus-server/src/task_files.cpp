#include "task_files.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "urs/util/cli.hpp"

namespace urs::camus_server::tasks {

namespace fs = std::filesystem;

std::vector<TaskFile> read_task_dir(const std::string& dir) {
  std::vector<fs::path> paths;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    auto ext = entry.path().extension().string();
    if (entry.is_regular_file() && (ext == ".yaml" || ext == ".yml")) paths.push_back(entry.path());
  }
  if (ec) throw util::ConfigError("--tasks-dir: cannot read '" + dir + "': " + ec.message());
  std::sort(paths.begin(), paths.end());
  std::vector<TaskFile> files;
  for (const auto& path : paths) {
    std::ifstream in(path);
    if (!in) throw util::ConfigError("--tasks-dir: cannot read '" + path.string() + "'");
    std::stringstream text;
    text << in.rdbuf();
    auto spec = parse_task(text.str(), path.stem().string());
    if (!spec.ok()) throw util::ConfigError("--tasks-dir: '" + path.string() + "': " + spec.message());
    files.push_back(TaskFile{path.string(), text.str(), std::move(spec.value())});
  }
  return files;
}

}  // namespace urs::camus_server::tasks
