#pragma once
// A Planet peer driven by hand over a real TCP connection, for tests that send what a
// well-behaved client never would (garbage, oversized frames, silence). Header-only; link
// urs::planet.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <deque>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "urs/planet/codec.hpp"

namespace urs::test {

// A TCP connection driven by hand. Reads are bounded by a timeout, never blocking forever.
class RawPeer {
 public:
  explicit RawPeer(uint16_t port) : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd_ < 0 || ::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      throw std::runtime_error("RawPeer cannot connect to port " + std::to_string(port));
    }
  }
  explicit RawPeer(int fd) : fd_(fd) {}
  ~RawPeer() {
    if (fd_ >= 0) ::close(fd_);
  }
  RawPeer(const RawPeer&) = delete;
  RawPeer& operator=(const RawPeer&) = delete;

  void send_bytes(const std::string& bytes) { send_bytes_checked(bytes); }
  void send_frame(const planet::Frame& frame) { send_bytes(planet::encode_frame(frame)); }
  // Like send_bytes / send_frame; false once the connection failed (e.g. the server closed it).
  bool send_bytes_checked(const std::string& bytes) {
    size_t offset = 0;
    while (offset < bytes.size()) {
      ssize_t sent = ::send(fd_, bytes.data() + offset, bytes.size() - offset, MSG_NOSIGNAL);
      if (sent <= 0) return false;
      offset += static_cast<size_t>(sent);
    }
    return true;
  }
  bool send_frame_checked(const planet::Frame& frame) { return send_bytes_checked(planet::encode_frame(frame)); }
  void send_hello(uint32_t version = planet::kProtocolVersion, const std::string& token = "",
                  const std::string& name = "raw", const std::string& session_secret = "",
                  planet::Role role = planet::CLIENT) {
    planet::Frame frame;
    frame.mutable_hello()->set_version(version);
    frame.mutable_hello()->set_token(token);
    frame.mutable_hello()->set_peer_name(name);
    frame.mutable_hello()->set_role(role);
    frame.mutable_hello()->set_session_secret(session_secret);
    send_frame(frame);
  }

  // The next frame, or nullopt on end of stream or after `timeout`.
  std::optional<planet::Frame> read_frame(std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (frames_.empty()) {
      if (eof_) return std::nullopt;
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
      if (left <= 0) return std::nullopt;
      pollfd poll_fd{fd_, POLLIN, 0};
      if (::poll(&poll_fd, 1, static_cast<int>(left)) <= 0) continue;
      char buffer[65536];
      const ssize_t got = ::recv(fd_, buffer, sizeof buffer, 0);
      if (got <= 0) {
        eof_ = true;
        continue;
      }
      try {
        decoder_.feed(std::string_view(buffer, static_cast<size_t>(got)),
                      [this](planet::Frame&& frame) { frames_.push_back(std::move(frame)); });
      } catch (const planet::ProtocolError&) {
        eof_ = true;
      }
    }
    planet::Frame frame = std::move(frames_.front());
    frames_.pop_front();
    return frame;
  }

  // The next frame that is not a Ping.
  std::optional<planet::Frame> read_non_ping(std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return std::nullopt;
      auto frame = read_frame(left);
      if (!frame || !frame->has_ping()) return frame;
    }
  }

  // Reads (and drops) frames until the server closes; false if it did not within `timeout`.
  bool closed_by_server(std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!eof_ && std::chrono::steady_clock::now() < deadline) {
      read_frame(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()));
    }
    return eof_;
  }

 private:
  int fd_;
  bool eof_ = false;
  static planet::CodecLimits reader_limits() {
    planet::CodecLimits limits;
    limits.max_frame_bytes = 64u << 20;  // whatever the server sends
    return limits;
  }
  planet::MessageDecoder decoder_{reader_limits()};
  std::deque<planet::Frame> frames_;
};

}  // namespace urs::test
