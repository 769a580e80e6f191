#include "dds_domain.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <stdexcept>
#include <string>

namespace urs::test {

namespace {
constexpr uint32_t kFirst = 10;
constexpr uint32_t kLast = 230;
constexpr const char* kDir = "/tmp/urs-dds-domains";
}  // namespace

DdsDomains::DdsDomains(unsigned count) {
  ::mkdir(kDir, 01777);
  ::chmod(kDir, 01777);  // shared by every user's tests
  const uint32_t span = kLast - kFirst + 1;
  const uint32_t start = static_cast<uint32_t>(::getpid()) % span;
  for (uint32_t step = 0; step < span && ids_.size() < count; ++step) {
    const uint32_t id = kFirst + (start + step) % span;
    const std::string path = std::string(kDir) + "/" + std::to_string(id);
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
    if (fd < 0) continue;
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      ::close(fd);
      continue;
    }
    ids_.push_back(id);
    fds_.push_back(fd);
  }
  if (ids_.size() < count) {
    for (int fd : fds_) ::close(fd);
    throw std::runtime_error("no free DDS domain in " + std::to_string(kFirst) + ".." + std::to_string(kLast) +
                             " (locks in " + kDir + ")");
  }
}

DdsDomains::~DdsDomains() {
  for (int fd : fds_) ::close(fd);
}

}  // namespace urs::test
