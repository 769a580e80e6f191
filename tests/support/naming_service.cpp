#include "naming_service.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <random>
#include <stdexcept>

namespace urs::test {
namespace {

sockaddr_in loopback(int port) {
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return address;
}

}  // namespace

int free_tcp_port() {
  // Below Linux's ephemeral range (32768..60999), where every process's own listening sockets
  // and outgoing connections take their ports, so the port stays free until it is used.
  static std::mt19937 random{std::random_device{}()};
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int port = std::uniform_int_distribution<int>(20000, 32000)(random);
    const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in address = loopback(port);
    const bool free = fd >= 0 && bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
    if (fd >= 0) close(fd);
    if (free) return port;
  }
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address = loopback(0);
  socklen_t length = sizeof address;
  if (fd < 0 || bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
    if (fd >= 0) close(fd);
    throw std::runtime_error("no free TCP port on 127.0.0.1");
  }
  close(fd);
  return ntohs(address.sin_port);
}

bool accepts_tcp(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  sockaddr_in address = loopback(port);
  const bool ok = connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
  close(fd);
  return ok;
}

NamingService::NamingService(const std::string& dir) {
  std::string failures;
  for (int attempt = 0; attempt < 5; ++attempt) {
    const std::string data_dir = dir + "/omninames-" + std::to_string(attempt);
    std::filesystem::create_directories(data_dir);
    port_ = free_tcp_port();
    process_ = std::make_unique<Process>(
        std::vector<std::string>{URS_OMNINAMES_BIN, "-start", std::to_string(port_), "-datadir", data_dir,
                                 "-ORBendPoint", "giop:tcp:127.0.0.1:" + std::to_string(port_)},
        dir + "/omninames.log");
    // Up means omniNames itself has bound the port and announced its root context: a bare TCP
    // answer could come from another process that took the port in the meantime.
    const auto up = [&] { return process_->log().find("Root context is") != std::string::npos && accepts_tcp(port_); };
    if (wait_until([&] { return !process_->running() || up(); }, std::chrono::seconds(10)) && process_->running() &&
        up()) {
      return;
    }
    failures += process_->log();
    process_.reset();
  }
  throw std::runtime_error("omniNames did not start:\n" + failures);
}

}  // namespace urs::test
