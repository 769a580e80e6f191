#include "recording_commands.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

namespace urs::cli {

namespace fs = std::filesystem;

namespace {

// The folder of this program, or "" if /proc cannot say.
fs::path program_dir() {
  std::error_code error;
  const auto exe = fs::read_symlink("/proc/self/exe", error);
  return error ? fs::path() : exe.parent_path();
}

const char* env(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && *value != '\0' ? value : nullptr;
}

}  // namespace

bool is_recording_command(int argc, char** argv) {
  return argc >= 2 && (std::strcmp(argv[1], "record") == 0 || std::strcmp(argv[1], "play") == 0);
}

int run_recording_command(int argc, char** argv) {
  const fs::path dir = program_dir();
  std::string sdk = env("URS_PYTHON_SDK") != nullptr ? env("URS_PYTHON_SDK") : "";
  if (sdk.empty() && !dir.empty() && fs::exists(dir / ".." / "share" / "urslink" / "python" / "urslink")) {
    sdk = (dir / ".." / "share" / "urslink" / "python").lexically_normal().string();
  }
  if (!sdk.empty()) {
    const char* path = env("PYTHONPATH");
    ::setenv("PYTHONPATH", (sdk + (path != nullptr ? ":" + std::string(path) : "")).c_str(), 1);
  }
  if (std::strcmp(argv[1], "play") == 0 && env("URS_GATEWAY_BIN") == nullptr && !dir.empty()) {
    // Installed side by side (bin/), or in the build tree (services/cli, services/gateway).
    for (const fs::path& candidate : {dir / "urs-gateway", dir / ".." / "gateway" / "urs-gateway"}) {
      if (::access(candidate.c_str(), X_OK) == 0) {
        ::setenv("URS_GATEWAY_BIN", candidate.lexically_normal().c_str(), 1);
        break;
      }
    }
  }
  const std::string python = env("URS_PYTHON") != nullptr ? env("URS_PYTHON") : "python3";
  std::vector<std::string> args{python, "-m", "urslink.recording"};
  for (int i = 1; i < argc; ++i) args.emplace_back(argv[i]);
  std::vector<char*> exec_argv;
  for (auto& arg : args) exec_argv.push_back(arg.data());
  exec_argv.push_back(nullptr);
  ::execvp(python.c_str(), exec_argv.data());
  std::cerr << "urs " << argv[1] << ": cannot run " << python << " (" << std::strerror(errno)
            << "): set URS_PYTHON to a Python 3 that has urslink, mcap and websockets\n";
  return 127;
}

}  // namespace urs::cli
