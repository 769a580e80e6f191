#include "ws_session.hpp"

#include <spdlog/spdlog.h>

#include <array>
#include <boost/asio/post.hpp>
#include <chrono>

#include "urs/gateway/protocol.hpp"

namespace urs::gateway {

namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;

WsSession::WsSession(tcp::socket&& socket, Hub& hub, Role role, std::string login, std::string identity,
                     std::size_t max_queue_bytes, std::atomic<std::size_t>& clients, std::string refusal)
    : ws_(std::move(socket)),
      hub_(hub),
      role_(role),
      login_(std::move(login)),
      identity_(std::move(identity)),
      max_queue_bytes_(max_queue_bytes),
      refusal_(std::move(refusal)),
      clients_(clients) {
  ++clients_;
}

WsSession::~WsSession() { --clients_; }

void WsSession::run(Request request) {
  beast::get_lowest_layer(ws_).expires_never();
  ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
  ws_.set_option(websocket::stream_base::decorator([](websocket::response_type& response) {
    response.set(http::field::server, "urs-gateway");
    response.set(http::field::sec_websocket_protocol, foxglove::kSubprotocol);
  }));
  ws_.read_message_max(foxglove::kMaxBinaryMessage);
  ws_.async_accept(request, [self = shared_from_this()](beast::error_code error) { self->on_accept(error); });
}

bool WsSession::send_text(std::string text) { return enqueue(Frame{std::move(text), nullptr, true}); }

bool WsSession::send_binary(std::string header, std::shared_ptr<const std::string> payload) {
  return enqueue(Frame{std::move(header), std::move(payload), false});
}

void WsSession::detach() {
  finish();
  beast::error_code ignored;
  beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
  beast::get_lowest_layer(ws_).socket().close(ignored);
}

void WsSession::end(std::string reason) {
  {
    std::lock_guard lock(mutex_);
    if (dropping_ || closed_) return;
    dropping_ = true;
    queue_.clear();
    queued_bytes_ = 0;
  }
  net::post(ws_.get_executor(), [self = shared_from_this(), reason = std::move(reason)] { self->close_with(reason); });
}

void WsSession::on_accept(beast::error_code error) {
  if (error) {
    spdlog::debug("gateway: WebSocket handshake failed: {}", error.message());
    return;
  }
  if (!refusal_.empty()) {
    refuse();
    return;
  }
  client_ = hub_.connect(shared_from_this(), role_, login_, identity_);
  connected_ = true;
  read();
}

void WsSession::read() {
  ws_.async_read(buffer_, [self = shared_from_this()](beast::error_code error, std::size_t) {
    if (error) {
      self->finish();
      return;
    }
    const auto data = self->buffer_.data();
    const std::string_view bytes(static_cast<const char*>(data.data()), data.size());
    if (self->ws_.got_text()) {
      self->hub_.receive_text(self->client_, bytes);
    } else {
      self->hub_.receive_binary(self->client_, bytes);
    }
    self->buffer_.consume(self->buffer_.size());
    self->read();
  });
}

bool WsSession::enqueue(Frame frame) {
  std::lock_guard lock(mutex_);
  if (dropping_ || closed_) return false;
  if (queued_bytes_ + frame.size() > max_queue_bytes_) {
    // Slower than what it subscribed to: dropped, and what waited for it freed at once.
    dropping_ = true;
    spdlog::warn("gateway: client {} is too slow ({} bytes waiting, at most {}); dropping it", client_.load(),
                 queued_bytes_, max_queue_bytes_);
    queue_.clear();
    queued_bytes_ = 0;
    net::post(ws_.get_executor(), [self = shared_from_this()] { self->close_with("too slow: dropped"); });
    return false;
  }
  queued_bytes_ += frame.size();
  queue_.push_back(std::move(frame));
  if (!writing_) {
    writing_ = true;
    net::post(ws_.get_executor(), [self = shared_from_this()] { self->write_next(); });
  }
  return true;
}

// On the I/O thread: one write at a time, in order.
void WsSession::write_next() {
  {
    std::lock_guard lock(mutex_);
    if (closed_ || dropping_ || queue_.empty()) {
      writing_ = false;
      return;
    }
    current_ = std::move(queue_.front());
    queue_.pop_front();
  }
  in_flight_ = true;
  ws_.text(current_.text);
  std::array<net::const_buffer, 2> buffers{net::buffer(current_.head),
                                           current_.payload ? net::buffer(*current_.payload) : net::const_buffer()};
  ws_.async_write(buffers, [self = shared_from_this()](beast::error_code error, std::size_t) {
    self->in_flight_ = false;
    {
      std::lock_guard lock(self->mutex_);
      const std::size_t size = self->current_.size();
      self->queued_bytes_ = self->queued_bytes_ >= size ? self->queued_bytes_ - size : 0;
      self->current_ = Frame{};
      if (error) {
        self->closed_ = true;
        self->writing_ = false;
        return;  // the read side sees the failure and finishes
      }
    }
    self->write_next();
  });
}

// On the I/O thread, once the client is too slow or its login ended: out of the hub at once, then
// a close (1008, policy violation) with `reason`, bounded; a peer that does not even take the
// write in flight has its connection cut instead (a close frame could not reach it).
void WsSession::close_with(const std::string& reason) {
  leave_hub();
  beast::error_code ignored;
  if (in_flight_) {
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).socket().close(ignored);
    return;
  }
  ws_.set_option(websocket::stream_base::timeout{std::chrono::seconds(5), std::chrono::seconds(5), false});
  // A close frame's reason holds at most 123 bytes.
  ws_.async_close(websocket::close_reason(websocket::close_code::policy_error, reason.substr(0, 123)),
                  [self = shared_from_this()](beast::error_code) { self->finish(); });
}

// On the I/O thread, after the handshake of a refused client: the Status, then the close.
void WsSession::refuse() {
  ws_.set_option(websocket::stream_base::timeout{std::chrono::seconds(5), std::chrono::seconds(5), false});
  ws_.text(true);
  current_ = Frame{foxglove::status(foxglove::StatusLevel::error, refusal_), nullptr, true};
  ws_.async_write(net::buffer(current_.head), [self = shared_from_this()](beast::error_code error, std::size_t) {
    if (error) {
      self->finish();
      return;
    }
    self->close_with(self->refusal_);
  });
}

void WsSession::finish() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
    queue_.clear();
    queued_bytes_ = 0;
  }
  leave_hub();
}

void WsSession::leave_hub() {
  if (connected_) {
    connected_ = false;
    hub_.disconnect(client_);
  }
}

}  // namespace urs::gateway
