#include "urs/util/files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "urs/util/cli.hpp"

namespace urs::util {

namespace {

const char* kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  return "not a regular file";
}

// Closes the descriptor on every path.
class Descriptor {
 public:
  explicit Descriptor(int fd) : fd_(fd) {}
  ~Descriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  Descriptor(const Descriptor&) = delete;
  Descriptor& operator=(const Descriptor&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

}  // namespace

std::string read_regular_file(const std::string& path, size_t max_bytes) {
  const Descriptor fd(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY));
  if (fd.get() < 0) throw ConfigError("'" + path + "' cannot be opened: " + std::strerror(errno));
  struct stat info {};
  if (::fstat(fd.get(), &info) != 0) throw ConfigError("'" + path + "' cannot be examined: " + std::strerror(errno));
  if (!S_ISREG(info.st_mode)) {
    throw ConfigError("'" + path + "' is " + kind_of(info.st_mode) + ", not a regular file");
  }
  if (static_cast<uint64_t>(info.st_size) > max_bytes) {
    throw ConfigError("'" + path + "' is " + std::to_string(info.st_size) + " bytes; the limit is " +
                      std::to_string(max_bytes));
  }
  std::string text;
  text.resize(static_cast<size_t>(info.st_size));
  size_t have = 0;
  for (;;) {
    // One byte more than the limit lets a file that grew since fstat be told apart.
    if (have == text.size() && text.size() <= max_bytes) text.resize(std::min(max_bytes + 1, text.size() + 4096));
    const ssize_t got = ::read(fd.get(), text.data() + have, text.size() - have);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) throw ConfigError("'" + path + "' cannot be read: " + std::strerror(errno));
    if (got == 0) break;
    have += static_cast<size_t>(got);
    if (have > max_bytes) {
      throw ConfigError("'" + path + "' grew past the limit of " + std::to_string(max_bytes) + " bytes while read");
    }
  }
  text.resize(have);
  return text;
}

}  // namespace urs::util
