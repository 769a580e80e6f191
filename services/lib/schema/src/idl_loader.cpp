// load_idl(): omniidl + the planet_proto back-end into a private temporary folder, then the
// generated .proto parsed with compiler::Importer. urs_options.proto and descriptor.proto are
// served from the descriptors compiled into this program, so no .proto file needs to be installed.
#include <dlfcn.h>
#include <fcntl.h>
#include <google/protobuf/compiler/importer.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <system_error>

#include "urs/schema/schema.hpp"
#include "urs_options.pb.h"

extern char** environ;

namespace urs::schema {

namespace gp = google::protobuf;
namespace fs = std::filesystem;

namespace {

constexpr std::size_t kMaxToolOutput = 256 * 1024;  // omniidl's messages kept for the error text

std::string env_or(const char* name, const char* fallback) {
  const char* value = std::getenv(name);
  return value != nullptr && *value != '\0' ? value : fallback;
}

// The back-end installed with this library (URS_LIB_TO_PLANET_BACKEND from the library's folder,
// share/urslink/idl/omniidl_planet of the package) when it is there; else the sources' folder.
std::string default_backend_dir() {
  Dl_info self{};
  if (::dladdr(reinterpret_cast<const void*>(&default_backend_dir), &self) != 0 && self.dli_fname != nullptr) {
    const fs::path installed = fs::path(self.dli_fname).parent_path() / URS_LIB_TO_PLANET_BACKEND;
    std::error_code ec;
    if (fs::is_regular_file(installed / "planet_proto.py", ec)) return installed.lexically_normal().string();
  }
  return URS_DEFAULT_PLANET_BACKEND_DIR;
}

// omniidl hands paths to its preprocessor through a shell, inside double quotes.
bool shell_safe(const std::string& path) { return path.find_first_of("\"$`\\") == std::string::npos; }

// A private temporary folder, removed with its content on destruction.
class TempDir {
 public:
  TempDir() {
    std::error_code ec;
    fs::path base = fs::temp_directory_path(ec);
    if (ec) base = "/tmp";
    std::string pattern = (base / "urs-idl-XXXXXX").string();
    if (::mkdtemp(pattern.data()) != nullptr)
      path_ = pattern;
    else
      error_ = "cannot create a temporary folder in " + base.string() + ": " + std::strerror(errno);
  }
  ~TempDir() {
    std::error_code ignored;
    if (!path_.empty()) fs::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::string& path() const { return path_; }
  const std::string& error() const { return error_; }

 private:
  std::string path_;
  std::string error_;
};

struct ToolRun {
  int exit_status = -1;  // -1: could not start or did not exit normally
  std::string output;    // stdout and stderr, interleaved
  std::string error;     // why it could not run
};

// Runs argv[0] (searched in PATH if it has no '/'), stdin from /dev/null, collecting its output.
ToolRun run_tool(const std::vector<std::string>& args) {
  ToolRun run;
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    run.error = std::string("pipe: ") + std::strerror(errno);
    return run;
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, fds[1], 1);
  posix_spawn_file_actions_adddup2(&actions, fds[1], 2);
  std::vector<char*> argv;
  for (const auto& arg : args) argv.push_back(const_cast<char*>(arg.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int spawned = ::posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  if (spawned != 0) {
    ::close(fds[0]);
    run.error = "cannot run '" + args[0] + "': " + std::strerror(spawned);
    return run;
  }
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n > 0) {
      if (run.output.size() < kMaxToolOutput) run.output.append(buffer, static_cast<std::size_t>(n));
    } else if (n == 0 || errno != EINTR) {
      break;
    }
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status))
    run.exit_status = WEXITSTATUS(status);
  else
    run.error = "'" + args[0] + "' was killed by signal " + std::to_string(WTERMSIG(status));
  return run;
}

// Files from the temporary folder first, then the .proto files compiled into this program.
class SourceTree final : public gp::compiler::SourceTree {
 public:
  explicit SourceTree(const std::string& dir) { disk_.MapPath("", dir); }

  gp::io::ZeroCopyInputStream* Open(const std::string& filename) override {
    if (gp::io::ZeroCopyInputStream* stream = disk_.Open(filename)) return stream;
    const gp::FileDescriptor* compiled = gp::DescriptorPool::generated_pool()->FindFileByName(filename);
    if (compiled == nullptr) return nullptr;
    texts_.push_back(compiled->DebugString());
    return new gp::io::ArrayInputStream(texts_.back().data(), static_cast<int>(texts_.back().size()));
  }

  std::string GetLastErrorMessage() override { return disk_.GetLastErrorMessage(); }

 private:
  gp::compiler::DiskSourceTree disk_;
  std::deque<std::string> texts_;  // stable addresses for the streams handed out
};

class ImportErrors final : public gp::compiler::MultiFileErrorCollector {
 public:
  void AddError(const std::string& filename, int line, int column, const std::string& message) override {
    if (!text_.empty()) text_ += "\n";
    text_ += filename;
    if (line >= 0) text_ += ":" + std::to_string(line + 1) + ":" + std::to_string(column + 1);
    text_ += ": " + message;
  }
  const std::string& text() const { return text_; }

 private:
  std::string text_;
};

}  // namespace

IdlLoad load_idl(const std::string& idl_path, const std::vector<std::string>& include_dirs) {
  IdlLoad out;
  // Makes sure urs_options.proto is in the generated pool, for SourceTree's fallback.
  (void)urs::options::MessageKind_descriptor();

  std::error_code ec;
  if (!fs::is_regular_file(idl_path, ec)) {
    out.error = "IDL file '" + idl_path + "' does not exist or is not a regular file";
    return out;
  }
  std::vector<std::string> paths = include_dirs;
  paths.push_back(idl_path);
  for (const auto& path : paths) {
    if (!shell_safe(path)) {
      out.error = "path '" + path + "' contains one of \" $ ` \\, which omniidl cannot pass to its preprocessor";
      return out;
    }
  }
  TempDir temp;
  if (!temp.error().empty()) {
    out.error = temp.error();
    return out;
  }

  const std::string omniidl = env_or("URS_OMNIIDL", URS_DEFAULT_OMNIIDL);
  const std::string backend = env_or("URS_OMNIIDL_BACKEND_DIR", default_backend_dir().c_str());
  std::vector<std::string> args = {omniidl, "-p", backend, "-b", "planet_proto", "-Wball", "-C", temp.path()};
  const fs::path idl_dir = fs::path(idl_path).parent_path();
  args.push_back("-I" + (idl_dir.empty() ? std::string(".") : idl_dir.string()));
  for (const auto& dir : include_dirs) args.push_back("-I" + dir);
  args.push_back(idl_path);

  const ToolRun run = run_tool(args);
  if (!run.error.empty()) {
    out.error = run.error + " (install the Debian package omniidl, or set URS_OMNIIDL to its path)";
    return out;
  }
  if (run.exit_status != 0) {
    std::string output = run.output;
    while (!output.empty() && (output.back() == '\n' || output.back() == ' ')) output.pop_back();
    out.error = "omniidl could not translate '" + idl_path + "' (exit status " + std::to_string(run.exit_status) +
                "; back-end folder " + backend + "):\n" + output;
    return out;
  }

  const std::string proto_name = fs::path(idl_path).stem().string() + ".proto";
  if (!fs::is_regular_file(fs::path(temp.path()) / proto_name, ec)) {
    out.error = "omniidl succeeded on '" + idl_path + "' but wrote no " + proto_name +
                " (is URS_OMNIIDL_BACKEND_DIR=" + backend + " the planet_proto back-end?)";
    return out;
  }
  SourceTree tree(temp.path());
  ImportErrors errors;
  gp::compiler::Importer importer(&tree, &errors);
  const gp::FileDescriptor* file = importer.Import(proto_name);
  if (file == nullptr) {
    out.error = "the schema generated from '" + idl_path + "' does not load (a translator bug, please report):\n" +
                errors.text();
    return out;
  }
  out.descriptor_set = descriptor_set_for(*file);
  for (int i = 0; i < file->service_count(); ++i) out.services.push_back(file->service(i)->full_name());
  return out;
}

}  // namespace urs::schema
