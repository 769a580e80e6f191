#include "urs/util/service_manager.hpp"

#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdlib>
#include <cstring>

namespace urs::util {

Notified notify_service_manager(const std::string& state) {
  const char* socket_name = std::getenv("NOTIFY_SOCKET");
  if (socket_name == nullptr || socket_name[0] == '\0') return Notified::kNoManager;
  const std::string name = socket_name;
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  // A path, or "@..." for the abstract namespace (a leading NUL byte instead of the '@').
  if ((name[0] != '/' && name[0] != '@') || name.size() >= sizeof(address.sun_path)) {
    spdlog::warn(
        "NOTIFY_SOCKET '{}' is neither an absolute path nor an abstract name (@...) of at most {} bytes: "
        "the service manager is not told '{}'",
        name, sizeof(address.sun_path) - 1, state);
    return Notified::kUnreachable;
  }
  std::memcpy(address.sun_path, name.data(), name.size());
  if (name[0] == '@') address.sun_path[0] = '\0';
  const auto length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + name.size());

  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    spdlog::warn("cannot tell the service manager '{}': socket: {}", state, std::strerror(errno));
    return Notified::kUnreachable;
  }
  const ssize_t sent =
      ::sendto(fd, state.data(), state.size(), MSG_NOSIGNAL, reinterpret_cast<const sockaddr*>(&address), length);
  const int error = errno;
  ::close(fd);
  if (sent != static_cast<ssize_t>(state.size())) {
    spdlog::warn("cannot tell the service manager '{}' on {}: {}", state, name,
                 sent < 0 ? std::strerror(error) : "short write");
    return Notified::kUnreachable;
  }
  return Notified::kSent;
}

}  // namespace urs::util
