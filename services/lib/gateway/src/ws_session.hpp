#pragma once
// The WebSocket of one Foxglove client (subprotocol foxglove.websocket.v1): accepts the upgrade,
// joins the Hub as this client's Outbox, hands the Hub every message the client sends, and writes
// what the Hub sends, one write at a time and in order.
//
// Limits: a client message of at most foxglove::kMaxBinaryMessage bytes; at most
// `max_queue_bytes` queued and not yet written. A client slower than what it subscribed to is
// dropped: out of the hub at once, what waited for it freed, then a close 1008 ("too slow:
// dropped") bounded by 5 s, or its connection cut if even the write in flight does not finish.
// end() closes a client the same way with a reason of its own (its login ended).
//
// A session made with a `refusal` never joins the hub: once the handshake is done it sends one
// Status (error level) saying `refusal` and closes with code 1008 and that reason, so a browser,
// which cannot read the body of a refused upgrade, shows why (Foxglove and Lichtblick list a
// Status among the connection's problems).
//
// Threads: run() and everything the socket does happen on the server's one I/O thread;
// send_text(), send_binary() and end() may be called from any thread (they only queue, under a
// lock, and never block); detach() only once the I/O thread has stopped.
// Ownership: shared; the I/O handlers in flight and the Hub (until the client leaves it) hold it,
// the server a weak reference (to detach it when it stops).
// `hub` and `clients` outlive every session; `clients` counts the live sessions.

#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>

#include "http_util.hpp"
#include "urs/gateway/hub.hpp"

namespace urs::gateway {

class WsSession : public Outbox, public std::enable_shared_from_this<WsSession> {
 public:
  // `login`, `identity`: the login's id and credential name (Caller); `refusal`: see above.
  WsSession(boost::asio::ip::tcp::socket&& socket, Hub& hub, Role role, std::string login, std::string identity,
            std::size_t max_queue_bytes, std::atomic<std::size_t>& clients, std::string refusal = {});
  ~WsSession() override;

  // Answers the upgrade `request`; once accepted, joins the hub and reads.
  void run(Request request);

  // Outbox
  bool send_text(std::string text) override;
  bool send_binary(std::string header, std::shared_ptr<const std::string> payload) override;

  // After the I/O thread has stopped: leaves the hub (nothing is sent any more) and closes.
  void detach();

  // Leaves the hub and closes with code 1008 and `reason` (at most 123 bytes are sent).
  void end(std::string reason);
  const std::string& login() const { return login_; }

 private:
  struct Frame {
    std::string head;
    std::shared_ptr<const std::string> payload;
    bool text = false;
    std::size_t size() const { return head.size() + (payload ? payload->size() : 0); }
  };

  void on_accept(beast::error_code error);
  void read();
  bool enqueue(Frame frame);
  void write_next();
  void close_with(const std::string& reason);
  void refuse();
  void finish();
  void leave_hub();

  beast::websocket::stream<beast::tcp_stream> ws_;
  Hub& hub_;
  const Role role_;
  const std::string login_;
  const std::string identity_;
  const std::size_t max_queue_bytes_;
  const std::string refusal_;
  std::atomic<std::size_t>& clients_;
  beast::flat_buffer buffer_;
  std::atomic<uint64_t> client_{0};  // set on the I/O thread, named in other threads' warnings
  bool connected_ = false;           // I/O thread's own
  bool in_flight_ = false;           // I/O thread's own: a write is under way

  std::mutex mutex_;  // guards the queue and the flags below
  std::deque<Frame> queue_;
  std::size_t queued_bytes_ = 0;
  bool writing_ = false;
  bool dropping_ = false;
  bool closed_ = false;
  Frame current_;  // being written (I/O thread)
};

}  // namespace urs::gateway
