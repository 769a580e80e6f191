#include "stream.hpp"

#include <sys/socket.h>

#include <cerrno>

namespace urs::planet::detail {
namespace {

class TcpStream final : public Stream {
 public:
  explicit TcpStream(asio::ip::tcp::socket socket) : socket_(std::move(socket)) {}

  asio::ip::tcp::socket& socket() override { return socket_; }
  bool secure() const override { return false; }
  void async_handshake(std::function<void(const std::error_code&)> handler) override {
    asio::post(socket_.get_executor(), [handler = std::move(handler)] { handler(std::error_code()); });
  }
  void async_read_some(asio::mutable_buffer buffer, Handler handler) override {
    socket_.async_read_some(buffer, std::move(handler));
  }
  void async_write(const std::vector<asio::const_buffer>& buffers, Handler handler) override {
    asio::async_write(socket_, buffers, std::move(handler));
  }
  long send_now(const iovec* iov, size_t count, std::error_code& error) override {
    msghdr message{};
    message.msg_iov = const_cast<iovec*>(iov);
    message.msg_iovlen = count;
    for (;;) {
      const ssize_t written = ::sendmsg(socket_.native_handle(), &message, MSG_DONTWAIT | MSG_NOSIGNAL);
      if (written >= 0) return static_cast<long>(written);
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) return 0;
      error = std::error_code(errno, std::system_category());
      return -1;
    }
  }

 private:
  asio::ip::tcp::socket socket_;
};

}  // namespace

std::unique_ptr<Stream> make_tcp_stream(asio::ip::tcp::socket socket) {
  return std::make_unique<TcpStream>(std::move(socket));
}

}  // namespace urs::planet::detail
