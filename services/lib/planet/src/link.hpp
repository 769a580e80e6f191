#pragma once
// One Planet connection (plain TCP or TLS, see stream.hpp), shared by the server's sessions and
// the client: read loop into a MessageDecoder, write loop out of an Outbox, heartbeats, and an
// orderly close that sends a final frame (Goodbye or Refused) before shutting the socket. The only
// code in the library that touches a socket besides the acceptor and the client's connector.
//
// Threading: every handler of a Link runs on its strand (the socket's executor). enqueue(),
// close_link(), closing() and peer_address() are thread-safe; everything marked "strand" must be
// called from the Link's own handlers (handle_frame and friends).
//
// Lifetime: the Link holds the io_context alive (a shared_ptr) so that a SessionPtr kept by the
// application after the Server is gone can still be destroyed safely. Asynchronous operations
// hold a shared_ptr to the Link; after finish() none is left.

#include <array>
#include <asio.hpp>
#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "stream.hpp"
#include "urs/planet/codec.hpp"

namespace urs::planet::detail {

struct LinkConfig {
  CodecLimits limits;
  uint32_t chunk_bytes = 64u << 10;            // outgoing frames above this are chunked
  size_t max_send_queue_bytes = 256ull << 20;  // beyond it the link closes itself
  std::chrono::milliseconds linger{1000};      // how long a final frame may take to go out
  // Where this link's send queue and reassembly buffers are counted (null: nowhere; a server
  // session gets its credential's share at the handshake, set_budget); a frame the budget
  // refuses closes the link with RESOURCE_EXHAUSTED and the budget's reason.
  std::shared_ptr<BufferBudget> budget;
};

Frame make_goodbye(Status status, const std::string& reason);

// The body of every Planet I/O thread (the server's and the client's): runs `io` until it stops
// or runs out of work; an exception escaping a handler is logged, naming `owner` ("server",
// "client"), and running resumes.
void run_io(asio::io_context& io, const char* owner);

// Logs `message` at warn, at most 5 per 10 s per source address (the host of `peer_address`,
// "host:port"), with the number suppressed in between: a peer cannot flood the log. For what a
// peer causes (protocol errors, refusals, timeouts).
void warn_peer(const std::string& peer_address, const std::string& message);

class Link : public std::enable_shared_from_this<Link> {
 public:
  Link(std::shared_ptr<asio::io_context> io, std::unique_ptr<Stream> stream, const LinkConfig& config);
  virtual ~Link();
  Link(const Link&) = delete;
  Link& operator=(const Link&) = delete;

  // Starts the TLS handshake, if any, then the read loop. Frames queued before the handshake
  // completes go out after it. Thread-safe; call once.
  void start();
  // Queues a frame; never blocks. False if the link is closing or closed, or if the frame would
  // take the send queue over max_send_queue_bytes (then the link closes with UNAVAILABLE).
  // When nothing is being written, the frame goes to the socket at once from the calling thread
  // (a non-blocking send; what the socket does not take is left to the strand).
  bool enqueue(const Frame& frame);
  // Same, taking the frame: a large one is sent without any copy of its payload. On false the
  // frame is left as it was.
  bool enqueue(Frame&& frame);
  // Closes: sends `final_frame` (if any) after dropping whatever else is queued, then shuts the
  // socket; handle_closed(reason) follows on the strand. Thread-safe and idempotent.
  void close_link(std::optional<Frame> final_frame, const std::string& reason);
  bool closing() const { return closing_.load(); }
  const std::string& peer_address() const { return peer_address_; }

 protected:
  // Strand: from now on the Link answers Ping with Pong and swallows Pong itself.
  void mark_open() { open_ = true; }
  // Strand: sends Ping every ping_interval and closes the link with "heartbeat timeout after N ms"
  // when nothing arrived for silence_timeout. Zero disables either.
  void set_heartbeat(std::chrono::milliseconds ping_interval, std::chrono::milliseconds silence_timeout);
  // Strand: limits for what arrives from now on, and the chunk size for what is queued next.
  void set_limits(const CodecLimits& limits, uint32_t chunk_bytes);
  // Strand: counts this link's buffers in `budget` from now on (what is held moves there), and
  // the limits set next with it.
  void set_budget(std::shared_ptr<BufferBudget> budget);
  // Strand (or after the io threads are gone): closes now, without a final frame.
  void finish(const std::string& reason);
  asio::any_io_executor executor() { return socket_.get_executor(); }
  // Strand, once the TLS handshake completed: the verified client-certificate name, or empty.
  std::string peer_certificate_name() const { return stream_->peer_certificate_name(); }
  bool secure() const { return stream_->secure(); }
  // Strand: the TLS handshake failed; default: log (rate-limited) and close.
  virtual void handle_handshake_failed(const std::string& reason);

  // Strand. A complete frame other than Goodbye (and, once open, Ping and Pong).
  virtual void handle_frame(Frame&& frame) = 0;
  // Strand. The peer said Goodbye; the link finishes right after.
  virtual void handle_goodbye(const Goodbye& goodbye);
  // Strand. Malformed or over-limit input; default: log at warn, Goodbye with the error, close.
  virtual void handle_protocol_error(const ProtocolError& error);
  // Strand. Exactly once, when the socket is closed; no handler runs after it.
  virtual void handle_closed(const std::string& reason) = 0;
  // For logs, e.g. "session 4 (127.0.0.1:50312)".
  virtual std::string describe() const { return peer_address_; }
  // Any thread. The link is closed because its send queue is over max_send_queue_bytes.
  virtual void handle_send_queue_full() {}

 private:
  void do_read();
  void on_read(const std::error_code& error, size_t size);
  void dispatch(Frame&& frame);
  template <typename Push>
  bool enqueue_with(size_t size, Push&& push);
  // With mutex_ held and this thread owning the batch (writing_): pops the next frames to write.
  bool fill_batch_locked();
  // Owner of the batch: writes what the socket takes now, without blocking, and advances
  // batch_sent_. True when the whole batch is written; false when the socket is full or, with
  // `error` set, when the write failed.
  bool write_now(std::error_code& error);
  void clear_batch();
  // With mutex_ held: brings this link's share of the budget in line with the send queue.
  void account_locked();
  void do_write();
  void write_rest_async();
  void do_close(std::optional<Frame> final_frame, const std::string& reason);
  void arm_ping();
  void arm_silence(std::chrono::steady_clock::time_point deadline);

  std::shared_ptr<asio::io_context> io_;  // first: destroyed last
  std::unique_ptr<Stream> stream_;
  asio::ip::tcp::socket& socket_;  // the TCP socket under stream_
  asio::steady_timer ping_timer_;
  asio::steady_timer silence_timer_;
  asio::steady_timer linger_timer_;
  LinkConfig config_;
  std::string peer_address_;

  // Strand state.
  MessageDecoder decoder_;
  std::array<char, 64 * 1024> read_buffer_;
  std::vector<asio::const_buffer> write_buffers_;
  bool open_ = false;
  std::atomic<bool> handshaken_{false};  // the stream's (TLS) handshake completed: writes may go out
  bool write_deferred_ = false;          // do_write ran before that
  bool finished_ = false;
  bool final_pending_ = false;
  std::string close_reason_;
  std::chrono::milliseconds ping_interval_{0};
  std::chrono::milliseconds silence_timeout_{0};
  std::chrono::steady_clock::time_point last_received_;
  uint64_t ping_nonce_ = 0;

  // Shared with other threads.
  std::atomic<bool> closing_{false};
  std::mutex mutex_;  // guards outbox_, writing_ and requested_reason_
  Outbox outbox_;
  bool writing_ = false;  // someone owns the batch: a do_write chain, or a direct write in enqueue
  std::string requested_reason_;
  size_t accounted_ = 0;  // send-queue bytes counted in config_.budget

  // The frames being written, owned by whoever set writing_ (under mutex_): the strand, or an
  // enqueue() writing directly while it holds mutex_.
  std::vector<WireFrame> batch_;
  size_t batch_bytes_ = 0;
  size_t batch_sent_ = 0;
};

}  // namespace urs::planet::detail
