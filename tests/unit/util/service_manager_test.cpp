// notify_service_manager: the sd_notify datagram reaches a real Unix socket named by $NOTIFY_SOCKET, a
// path or an abstract name; without the variable nothing is sent, and a bad one is a typed refusal.

#include "urs/util/service_manager.hpp"

#include <gtest/gtest.h>
#include <poll.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstddef>
#include <cstring>
#include <string>

namespace {

using urs::util::Notified;
using urs::util::notify_ready;
using urs::util::notify_service_manager;

// A datagram socket bound where a service manager would listen; restores $NOTIFY_SOCKET afterwards.
class ManagerSocket {
 public:
  // `name`: a path, or "@..." for an abstract name.
  explicit ManagerSocket(const std::string& name) : name_(name) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    EXPECT_GE(fd_, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::memcpy(address.sun_path, name.data(), name.size());
    if (name[0] == '@') address.sun_path[0] = '\0';
    if (name[0] == '/') ::unlink(name.c_str());
    const auto length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + name.size());
    EXPECT_EQ(::bind(fd_, reinterpret_cast<const sockaddr*>(&address), length), 0) << std::strerror(errno);
    ::setenv("NOTIFY_SOCKET", name.c_str(), 1);
  }
  ~ManagerSocket() {
    ::unsetenv("NOTIFY_SOCKET");
    ::close(fd_);
    if (name_[0] == '/') ::unlink(name_.c_str());
  }
  // The next datagram, or "" when none arrives within a second.
  std::string receive() const {
    pollfd ready{fd_, POLLIN, 0};
    if (::poll(&ready, 1, 1000) != 1) return "";
    char buffer[512];
    const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
    return n > 0 ? std::string(buffer, static_cast<size_t>(n)) : "";
  }

 private:
  std::string name_;
  int fd_ = -1;
};

TEST(ServiceManager, WithoutNotifySocketNothingIsSent) {
  ::unsetenv("NOTIFY_SOCKET");
  EXPECT_EQ(notify_ready(), Notified::kNoManager);
}

TEST(ServiceManager, ReadyReachesASocketPath) {
  const std::string path = ::testing::TempDir() + "urs-notify-" + std::to_string(::getpid());
  ManagerSocket manager(path);
  EXPECT_EQ(notify_ready(), Notified::kSent);
  EXPECT_EQ(manager.receive(), "READY=1");
  EXPECT_EQ(notify_service_manager("STATUS=serving\nSTOPPING=1"), Notified::kSent);
  EXPECT_EQ(manager.receive(), "STATUS=serving\nSTOPPING=1");
}

TEST(ServiceManager, ReadyReachesAnAbstractSocket) {
  ManagerSocket manager("@urs-notify-test-" + std::to_string(::getpid()));
  EXPECT_EQ(notify_ready(), Notified::kSent);
  EXPECT_EQ(manager.receive(), "READY=1");
}

TEST(ServiceManager, AnUnusableSocketIsReportedNotFatal) {
  ::setenv("NOTIFY_SOCKET", "relative/path", 1);
  EXPECT_EQ(notify_ready(), Notified::kUnreachable);
  ::setenv("NOTIFY_SOCKET", (::testing::TempDir() + "urs-nobody-listens-here").c_str(), 1);
  EXPECT_EQ(notify_ready(), Notified::kUnreachable);
  ::setenv("NOTIFY_SOCKET", ("/" + std::string(200, 'x')).c_str(), 1);
  EXPECT_EQ(notify_ready(), Notified::kUnreachable);
  ::unsetenv("NOTIFY_SOCKET");
}

}  // namespace
