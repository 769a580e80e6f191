#include "link.hpp"

#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/uio.h>

#include <cerrno>

#include "urs/planet/status.hpp"
#include "urs/util/rate_limit.hpp"

namespace urs::planet::detail {
namespace {

// Gather buffers per sendmsg() (the kernel accepts up to IOV_MAX = 1024).
constexpr size_t kMaxIovecs = 64;

std::string endpoint_text(const asio::ip::tcp::socket& socket) {
  std::error_code error;
  auto endpoint = socket.remote_endpoint(error);
  if (error) return "?";
  const auto address = endpoint.address();
  const std::string host = address.is_v6() ? "[" + address.to_string() + "]" : address.to_string();
  return host + ":" + std::to_string(endpoint.port());
}

CodecLimits with_budget(CodecLimits limits, const std::shared_ptr<BufferBudget>& budget) {
  limits.budget = budget;
  return limits;
}

}  // namespace

void warn_peer(const std::string& peer_address, const std::string& message) {
  static util::RateLimiter limiter(5, std::chrono::seconds(10));
  if (!spdlog::should_log(spdlog::level::warn)) return;
  const size_t colon = peer_address.rfind(':');
  const std::string host = colon == std::string::npos ? peer_address : peer_address.substr(0, colon);
  uint64_t suppressed = 0;
  if (!limiter.allow(host, suppressed)) return;
  spdlog::warn("planet: {}{}", message, util::suppressed_note(suppressed));
}

void run_io(asio::io_context& io, const char* owner) {
  for (;;) {
    try {
      io.run();
      return;
    } catch (const std::exception& exception) {
      spdlog::error("planet: {} I/O thread caught: {}", owner, exception.what());
    }
  }
}

Frame make_goodbye(Status status, const std::string& reason) {
  Frame frame;
  frame.mutable_goodbye()->set_status(status);
  frame.mutable_goodbye()->set_reason(reason);
  return frame;
}

Link::Link(std::shared_ptr<asio::io_context> io, std::unique_ptr<Stream> stream, const LinkConfig& config)
    : io_(std::move(io)),
      stream_(std::move(stream)),
      socket_(stream_->socket()),
      ping_timer_(socket_.get_executor()),
      silence_timer_(socket_.get_executor()),
      linger_timer_(socket_.get_executor()),
      config_(config),
      peer_address_(endpoint_text(socket_)),
      decoder_(with_budget(config.limits, config.budget)),
      outbox_(config.chunk_bytes) {
  std::error_code ignored;
  socket_.set_option(asio::ip::tcp::no_delay(true), ignored);
}

Link::~Link() {
  if (config_.budget) config_.budget->give(accounted_);
}

void Link::account_locked() {
  if (!config_.budget) return;
  const size_t now = outbox_.queued_bytes();
  if (now > accounted_) config_.budget->force(now - accounted_);
  if (now < accounted_) config_.budget->give(accounted_ - now);
  accounted_ = now;
}

void Link::set_budget(std::shared_ptr<BufferBudget> budget) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (config_.budget) config_.budget->give(accounted_);
  config_.budget = std::move(budget);
  if (config_.budget) config_.budget->force(accounted_);
}

void Link::start() {
  asio::post(socket_.get_executor(), [self = shared_from_this()] {
    if (self->finished_) return;
    self->stream_->async_handshake([self](const std::error_code& error) {
      if (self->finished_) return;
      if (error) {
        self->handle_handshake_failed("TLS handshake failed: " + error.message());
        return;
      }
      self->handshaken_ = true;
      self->do_read();
      if (self->write_deferred_) {
        self->write_deferred_ = false;
        self->do_write();
      }
    });
  });
}

void Link::handle_handshake_failed(const std::string& reason) {
  warn_peer(peer_address_, "closing " + describe() + ": " + reason);
  finish(reason);
}

bool Link::enqueue(const Frame& frame) {
  return enqueue_with(frame.ByteSizeLong(), [&] { outbox_.push(frame); });
}

bool Link::enqueue(Frame&& frame) {
  return enqueue_with(frame.ByteSizeLong(), [&] { outbox_.push(std::move(frame)); });
}

template <typename Push>
bool Link::enqueue_with(size_t size, Push&& push) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (closing_.load()) return false;
  if (outbox_.queued_bytes() + size > config_.max_send_queue_bytes) {
    const std::string reason = "send queue of " + std::to_string(outbox_.queued_bytes() + size) +
                               " bytes exceeds max_send_queue_bytes " + std::to_string(config_.max_send_queue_bytes) +
                               " (the peer does not read fast enough)";
    lock.unlock();
    warn_peer(peer_address_, "closing " + describe() + ": " + reason);
    handle_send_queue_full();
    close_link(make_goodbye(Status::UNAVAILABLE, reason), reason);
    return false;
  }
  std::string refusal;
  if (config_.budget && !config_.budget->take(size, refusal)) {
    const std::string reason = "a frame of " + std::to_string(size) + " bytes for this connection refused: " + refusal;
    lock.unlock();
    warn_peer(peer_address_, "closing " + describe() + ": " + reason);
    close_link(make_goodbye(Status::RESOURCE_EXHAUSTED, reason), reason);
    return false;
  }
  accounted_ += config_.budget ? size : 0;  // taken above
  push();
  account_locked();
  if (writing_) return true;  // the writer picks it up in its turn
  if (!handshaken_.load()) {
    // TLS before its handshake completed: the strand writes once it has.
    writing_ = true;
    lock.unlock();
    asio::post(socket_.get_executor(), [self = shared_from_this()] { self->do_write(); });
    return true;
  }
  // Nothing is being written: this thread becomes the writer and sends right away (a
  // non-blocking send, under mutex_ so that finish() cannot close the socket meanwhile) instead
  // of waking the strand. Whatever is left (the socket is full, more is queued, an error) goes
  // to the strand.
  writing_ = true;
  if (fill_batch_locked()) {
    std::error_code error;
    if (write_now(error) && outbox_.empty()) {
      clear_batch();
      writing_ = false;
      return true;
    }
  }
  lock.unlock();
  asio::post(socket_.get_executor(), [self = shared_from_this()] { self->do_write(); });
  return true;
}

void Link::close_link(std::optional<Frame> final_frame, const std::string& reason) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closing_.exchange(true)) return;
    requested_reason_ = reason;
  }
  asio::post(socket_.get_executor(), [self = shared_from_this(), final_frame = std::move(final_frame),
                                      reason]() mutable { self->do_close(std::move(final_frame), reason); });
}

void Link::do_close(std::optional<Frame> final_frame, const std::string& reason) {
  if (finished_) return;
  if (close_reason_.empty()) close_reason_ = reason;
  ping_timer_.cancel();
  silence_timer_.cancel();
  if (!final_frame || !socket_.is_open() || !handshaken_) {
    finish(reason);
    return;
  }
  final_pending_ = true;
  bool start_writing = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    outbox_.clear();
    outbox_.push(*final_frame);
    account_locked();
    if (!writing_) writing_ = start_writing = true;
  }
  linger_timer_.expires_after(config_.linger);
  linger_timer_.async_wait([self = shared_from_this()](const std::error_code& error) {
    if (!error) self->finish("final frame not sent within the linger time");
  });
  if (start_writing) do_write();
}

void Link::finish(const std::string& reason) {
  if (finished_) return;
  finished_ = true;
  std::string requested;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closing_.store(true);
    outbox_.clear();
    account_locked();
    requested = requested_reason_;
    // Closed under mutex_: enqueue() writes to the socket directly while holding it.
    std::error_code ignored;
    socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
    socket_.close(ignored);
  }
  ping_timer_.cancel();
  silence_timer_.cancel();
  linger_timer_.cancel();
  // The reason of the close that was asked for first wins over what happened while closing.
  handle_closed(!close_reason_.empty() ? close_reason_ : !requested.empty() ? requested : reason);
}

void Link::set_heartbeat(std::chrono::milliseconds ping_interval, std::chrono::milliseconds silence_timeout) {
  ping_interval_ = ping_interval;
  silence_timeout_ = silence_timeout;
  last_received_ = std::chrono::steady_clock::now();
  ping_timer_.cancel();
  silence_timer_.cancel();
  if (ping_interval_.count() > 0) arm_ping();
  if (silence_timeout_.count() > 0) arm_silence(last_received_ + silence_timeout_);
}

void Link::set_limits(const CodecLimits& limits, uint32_t chunk_bytes) {
  decoder_.set_limits(with_budget(limits, config_.budget));
  std::lock_guard<std::mutex> lock(mutex_);
  outbox_.set_chunk_bytes(chunk_bytes);
}

void Link::arm_ping() {
  ping_timer_.expires_after(ping_interval_);
  ping_timer_.async_wait([self = shared_from_this()](const std::error_code& error) {
    if (error || self->finished_ || self->closing_.load()) return;
    Frame ping;
    ping.mutable_ping()->set_nonce(++self->ping_nonce_);
    self->enqueue(ping);
    self->arm_ping();
  });
}

void Link::arm_silence(std::chrono::steady_clock::time_point deadline) {
  silence_timer_.expires_at(deadline);
  silence_timer_.async_wait([self = shared_from_this()](const std::error_code& error) {
    if (error || self->finished_ || self->closing_.load()) return;
    const auto next = self->last_received_ + self->silence_timeout_;
    if (std::chrono::steady_clock::now() < next) {
      self->arm_silence(next);
      return;
    }
    const std::string reason = "heartbeat timeout after " + std::to_string(self->silence_timeout_.count()) + " ms";
    warn_peer(self->peer_address_, "closing " + self->describe() + ": " + reason);
    self->close_link(make_goodbye(Status::UNAVAILABLE, reason), reason);
  });
}

void Link::do_read() {
  if (finished_) return;
  stream_->async_read_some(
      asio::buffer(read_buffer_),
      [self = shared_from_this()](const std::error_code& error, size_t size) { self->on_read(error, size); });
}

void Link::on_read(const std::error_code& error, size_t size) {
  if (finished_) return;
  if (error) {
    // While a final frame is going out, its write (or the linger timer) ends the link.
    if (final_pending_) return;
    // A TLS peer that closes without close_notify: "stream truncated", the same for Planet.
    const bool closed = error == asio::error::eof || error == asio::ssl::error::stream_truncated;
    finish(closed ? "connection closed by peer" : "read failed: " + error.message());
    return;
  }
  if (!closing_.load()) {
    const uint64_t before = decoder_.frames_decoded();
    try {
      decoder_.feed(std::string_view(read_buffer_.data(), size), [this](Frame&& frame) { dispatch(std::move(frame)); });
    } catch (const ProtocolError& protocol_error) {
      if (!closing_.load()) handle_protocol_error(protocol_error);
    }
    if (decoder_.frames_decoded() != before) last_received_ = std::chrono::steady_clock::now();
  }
  do_read();
}

void Link::dispatch(Frame&& frame) {
  if (closing_.load()) return;  // nothing is delivered once a close has begun
  if (frame.has_goodbye()) {
    handle_goodbye(frame.goodbye());
    if (close_reason_.empty()) {
      close_reason_ =
          "goodbye from peer (" + std::string(status_name(frame.goodbye().status())) + "): " + frame.goodbye().reason();
    }
    finish(close_reason_);
    return;
  }
  if (open_) {
    if (frame.has_ping()) {
      Frame pong;
      pong.mutable_pong()->set_nonce(frame.ping().nonce());
      enqueue(pong);
      return;
    }
    if (frame.has_pong()) return;
  }
  try {
    handle_frame(std::move(frame));
  } catch (const std::exception& exception) {
    // A bug in a handler must not take the I/O thread down; this one connection pays for it.
    const std::string reason = std::string("internal error: ") + exception.what();
    spdlog::error("planet: closing {}: handler threw: {}", describe(), exception.what());
    close_link(make_goodbye(Status::INTERNAL, reason), reason);
  }
}

void Link::handle_goodbye(const Goodbye&) {}

void Link::handle_protocol_error(const ProtocolError& error) {
  warn_peer(peer_address_, "closing " + describe() + ": protocol error " +
                               std::string(protocol_error_name(error.code())) + ": " + error.what());
  close_link(make_goodbye(error.status(), error.what()), std::string("protocol error: ") + error.what());
}

bool Link::fill_batch_locked() {
  // About one chunk per batch, so that what is queued meanwhile (a small call behind a large
  // message) waits for at most one chunk; small frames are batched together. Larger batches
  // would be cheaper for the large message but would let it fill the socket ahead of a small
  // frame queued a moment later (the receiver then reads the whole message first).
  const size_t budget = std::max<size_t>(config_.chunk_bytes, 16 * 1024);
  while (batch_bytes_ < budget) {
    std::optional<WireFrame> frame = outbox_.pop_wire();
    if (!frame) break;
    batch_bytes_ += frame->size();
    batch_.push_back(std::move(*frame));
  }
  account_locked();
  return !batch_.empty();
}

void Link::clear_batch() {
  batch_.clear();
  batch_bytes_ = 0;
  batch_sent_ = 0;
}

bool Link::write_now(std::error_code& error) {
  iovec iov[kMaxIovecs];
  while (batch_sent_ < batch_bytes_) {
    size_t count = 0;
    size_t requested = 0;
    size_t skip = batch_sent_;
    auto add = [&](const char* data, size_t size) {
      if (skip >= size) {
        skip -= size;
        return true;
      }
      if (count == kMaxIovecs) return false;
      iov[count].iov_base = const_cast<char*>(data + skip);
      iov[count].iov_len = size - skip;
      requested += size - skip;
      ++count;
      skip = 0;
      return true;
    };
    for (const WireFrame& frame : batch_) {
      if (!add(frame.head.data(), frame.head.size())) break;
      bool full = false;
      for (std::string_view range : frame.body) {
        if (!add(range.data(), range.size())) {
          full = true;
          break;
        }
      }
      if (full || !add(frame.tail.data(), frame.tail.size())) break;
    }
    const long written = stream_->send_now(iov, count, error);
    if (written <= 0) return false;  // an error, or the socket is full
    batch_sent_ += static_cast<size_t>(written);
    if (static_cast<size_t>(written) < requested) return false;  // the socket is full
  }
  return !stream_->has_pending_output();  // TLS: encrypted, but not all written yet
}

void Link::do_write() {
  if (finished_) return;
  if (!handshaken_) {
    write_deferred_ = true;  // start() writes once the handshake completed
    return;
  }
  if (stream_->has_pending_output()) {
    write_rest_async();  // TLS: what send_now encrypted first
    return;
  }
  if (batch_sent_ == batch_bytes_) {
    bool idle = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      clear_batch();
      if (!fill_batch_locked()) {
        writing_ = false;
        idle = true;
      }
    }
    // Once idle, the batch belongs to whichever thread sends next: not touched here any more.
    if (idle) {
      if (final_pending_) finish(close_reason_);
      return;
    }
  }
  std::error_code error;
  if (!write_now(error)) {
    if (error) {
      finish("write failed: " + error.message());
    } else {
      write_rest_async();  // the socket is full: let asio wait until it drains
    }
    return;
  }
  bool idle = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (outbox_.empty()) {
      clear_batch();
      writing_ = false;
      idle = true;
    }
  }
  if (!idle) {
    // More to write: one batch per turn, so that the connection's reads and timers run in
    // between and frames queued meanwhile (by any thread) get their turn after this chunk.
    asio::post(socket_.get_executor(), [self = shared_from_this()] { self->do_write(); });
    return;
  }
  if (final_pending_) finish(close_reason_);
}

void Link::write_rest_async() {
  write_buffers_.clear();
  size_t skip = batch_sent_;
  auto add = [&](const char* data, size_t size) {
    if (skip >= size) {
      skip -= size;
      return;
    }
    write_buffers_.push_back(asio::buffer(data + skip, size - skip));
    skip = 0;
  };
  for (const WireFrame& frame : batch_) {
    add(frame.head.data(), frame.head.size());
    for (std::string_view range : frame.body) add(range.data(), range.size());
    add(frame.tail.data(), frame.tail.size());
  }
  stream_->async_write(write_buffers_, [self = shared_from_this()](const std::error_code& error, size_t) {
    if (self->finished_) return;
    if (error) {
      self->finish("write failed: " + error.message());
      return;
    }
    self->batch_sent_ = self->batch_bytes_;
    self->do_write();
  });
}

}  // namespace urs::planet::detail
