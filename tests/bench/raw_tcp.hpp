#pragma once
// The wire's floor for urs-bench: length-prefixed messages over TCP on loopback, with nothing
// parsed. RawEcho answers each message with a thread per connection; RawRelay stands between a
// client and a RawEcho as a Planet server stands between a client and a SAM (each message read
// whole, then written on), so "client → relay → echo" is the cost of the wire of a two-hop call.
//
// A message of exactly 4 bytes asks for a reply of that many bytes (big-endian), as
// URS::Diagnostic's blob(size) does: a small request, a large reply. Any other message is echoed.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "pinning.hpp"

namespace urs::bench {

inline bool send_all(int fd, const char* data, size_t n) {
  while (n > 0) {
    ssize_t w = ::send(fd, data, n, MSG_NOSIGNAL);
    if (w <= 0) return false;
    data += w;
    n -= static_cast<size_t>(w);
  }
  return true;
}

// Length prefix and body in one writev, so that a small message is one segment (the floor must
// not be inflated by an extra wake-up per message).
inline bool send_message(int fd, const char* data, uint32_t n) {
  uint32_t prefix = htonl(n);
  iovec parts[2] = {{&prefix, 4}, {const_cast<char*>(data), n}};
  ssize_t w = ::writev(fd, parts, 2);
  if (w <= 0) return false;
  size_t sent = static_cast<size_t>(w);
  if (sent < 4) {  // a partial write: finish with plain sends
    if (!send_all(fd, reinterpret_cast<char*>(&prefix) + sent, 4 - sent)) return false;
    sent = 4;
  }
  return send_all(fd, data + (sent - 4), n - (sent - 4));
}

inline bool recv_all(int fd, char* data, size_t n) {
  while (n > 0) {
    ssize_t r = ::recv(fd, data, n, 0);
    if (r <= 0) return false;
    data += r;
    n -= static_cast<size_t>(r);
  }
  return true;
}

// One whole message into `buffer`; false when the peer closed or broke the framing.
inline bool recv_message(int fd, std::string& buffer) {
  uint32_t n = 0;
  if (!recv_all(fd, reinterpret_cast<char*>(&n), 4)) return false;
  buffer.resize(ntohl(n));
  return recv_all(fd, buffer.data(), buffer.size());
}

// The request asking for a reply of `size` bytes.
inline std::string blob_request(uint32_t size) {
  const uint32_t wire = htonl(size);
  return std::string(reinterpret_cast<const char*>(&wire), 4);
}

// A connection to `host` (an IPv4 address) and `port`, TCP_NODELAY set; throws when it fails.
inline int connect_to(const std::string& host, uint16_t port) {
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  if (::inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
    ::close(fd);
    throw std::runtime_error("cannot connect to " + host + ": not an IPv4 address");
  }
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    throw std::runtime_error("cannot connect to " + host + ":" + std::to_string(port) + ": " + why);
  }
  int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
  return fd;
}

inline int connect_loopback(uint16_t port) { return connect_to("127.0.0.1", port); }

// One request, one reply, on a connected socket.
inline void round_trip(int fd, const std::string& request, std::string& reply) {
  if (!send_message(fd, request.data(), static_cast<uint32_t>(request.size())) || !recv_message(fd, reply)) {
    throw std::runtime_error("raw TCP round trip failed");
  }
}

// A listening socket on 127.0.0.1 whose every connection is served by `serve(fd)` on a thread
// of its own; the destructor stops accepting and joins them once their peers have closed.
class RawListener {
 public:
  template <class Serve>
  explicit RawListener(Serve serve) {
    listener_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof(addr);
    if (::bind(listener_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 || ::listen(listener_, 16) != 0 ||
        ::getsockname(listener_, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
      ::close(listener_);
      throw std::runtime_error("cannot listen on 127.0.0.1");
    }
    port_ = ntohs(addr.sin_port);
    thread_ = std::thread([this, serve] {
      pin_server_thread();  // its connections' threads inherit the CPU
      std::vector<std::thread> connections;
      for (;;) {
        int fd = ::accept(listener_, nullptr, nullptr);
        if (fd < 0) break;
        int one = 1;
        ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
        connections.emplace_back([fd, serve] {
          serve(fd);
          ::close(fd);
        });
      }
      for (auto& connection : connections) connection.join();
    });
  }
  ~RawListener() {
    ::shutdown(listener_, SHUT_RDWR);
    ::close(listener_);
    thread_.join();
  }
  RawListener(const RawListener&) = delete;
  RawListener& operator=(const RawListener&) = delete;
  uint16_t port() const { return port_; }

 private:
  int listener_ = -1;
  uint16_t port_ = 0;
  std::thread thread_;
};

// Answers the messages of one connection until it closes: a 4-byte message with that many bytes,
// any other with itself.
inline void serve_echo(int fd) {
  std::string message;
  std::string blob;
  while (recv_message(fd, message)) {
    const std::string* reply = &message;
    if (message.size() == 4) {
      uint32_t size = 0;
      std::memcpy(&size, message.data(), 4);
      blob.assign(ntohl(size), 'x');
      reply = &blob;
    }
    if (!send_message(fd, reply->data(), static_cast<uint32_t>(reply->size()))) break;
  }
}

class RawEcho {
 public:
  RawEcho() : listener_(serve_echo) {}
  uint16_t port() const { return listener_.port(); }

 private:
  RawListener listener_;
};

// Forwards each whole message of a client to the upstream server on a connection of its own, and
// the upstream's reply back: the work of a relay that parses nothing.
class RawRelay {
 public:
  explicit RawRelay(uint16_t upstream)
      : listener_([upstream](int fd) {
          const int up = connect_loopback(upstream);
          std::string message;
          while (recv_message(fd, message)) {
            if (!send_message(up, message.data(), static_cast<uint32_t>(message.size())) ||
                !recv_message(up, message) ||
                !send_message(fd, message.data(), static_cast<uint32_t>(message.size()))) {
              break;
            }
          }
          ::close(up);
        }) {}
  uint16_t port() const { return listener_.port(); }

 private:
  RawListener listener_;
};

}  // namespace urs::bench
