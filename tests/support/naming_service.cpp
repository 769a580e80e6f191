#include "naming_service.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
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
    if (wait_until([&] { return !process_->running() || accepts_tcp(port_); }, std::chrono::seconds(10)) &&
        process_->running()) {
      return;
    }
    failures += process_->log();
    process_.reset();
  }
  throw std::runtime_error("omniNames did not start:\n" + failures);
}

}  // namespace urs::test
