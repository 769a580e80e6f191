#pragma once
// Planet framing codec: bytes in, Frames out, and Frames in, bytes out. No sockets here: the
// transport feeds whatever slices it read and writes whatever the Outbox hands it, so every piece
// is unit-testable (and fuzzable) on plain byte strings. Specification: docs/planet.md.
// One part a file under src/: codec.cpp (errors, limits), frame_decoder.cpp, reassembler.cpp,
// message_decoder.cpp, frame_encoder.cpp, outbox.cpp.
//
// Wire format: every frame is a 4-byte big-endian length N followed by N bytes of one serialized
// `urs.planet.Frame`. A Frame that serializes to more than `chunk_bytes` travels as a run of
// `Chunk` frames carrying its bytes; the receiver reassembles them.
//
// Errors: malformed or over-limit input throws ProtocolError (the one exception on the data path,
// thrown only at this boundary). After a ProtocolError the byte stream is out of sync: the caller
// closes the connection and drops the decoder.
//
// Threading: none of these classes is thread-safe; each belongs to one connection.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "planet.pb.h"

namespace urs::planet {

// The protocol version this library speaks (Hello.version / Welcome.version).
inline constexpr uint32_t kProtocolVersion = 1;
// Size of the big-endian length prefix in front of every frame.
inline constexpr size_t kLengthPrefixBytes = 4;
// Bytes a Chunk frame adds around its data (Frame tag + length, ids, offset, last); the data of
// one piece is chunk_bytes - kChunkOverheadBytes, so a Chunk frame never exceeds chunk_bytes.
inline constexpr size_t kChunkOverheadBytes = 64;
// Smallest chunk_bytes a sender or receiver may be configured with.
inline constexpr uint32_t kMinChunkBytes = 512;
// Largest single frame the format can describe (the length prefix is 32 bits) and largest message
// protobuf can parse; max_message_bytes is clamped to this.
inline constexpr uint64_t kMaxMessageBytesCeiling = (1ull << 31) - 1;

// Appends to `errors` one message per limit that is out of range (client and server options
// share these rules).
void check_message_limits(uint32_t chunk_bytes, uint64_t max_message_bytes, std::vector<std::string>& errors);

enum class ProtocolErrorCode {
  kFrameTooLarge,           // length prefix over max_frame_bytes
  kEmptyFrame,              // length prefix 0
  kMalformedFrame,          // bytes do not parse as a Frame, or no known body
  kMessageTooLarge,         // Chunk.total_bytes over max_message_bytes
  kTooManyPartialMessages,  // more concurrent chunked messages than max_partial_messages
  kInconsistentChunk,       // total_bytes changes, offset gap, last flag wrong, empty piece
  kUnknownChunk,            // a continuation piece of a message id never started
  kChunkOverflow,           // pieces add up to more than total_bytes
  kNestedChunk,             // a reassembled message is itself a Chunk
  kChunkBeforeHandshake,    // a Chunk frame before the handshake completed
  kReassemblyLimit,         // chunked messages in progress over max_reassembly_bytes
  kServerBudget,            // the server's buffer budget (max_buffered_bytes, its share) would be exceeded
};

// Stable name of a code, e.g. "FRAME_TOO_LARGE".
std::string_view protocol_error_name(ProtocolErrorCode code);

// Malformed or over-limit input at the codec boundary. what() names the value, the limit and,
// for limits, how to raise them.
class ProtocolError : public std::runtime_error {
 public:
  ProtocolError(ProtocolErrorCode code, const std::string& message);
  ProtocolErrorCode code() const { return code_; }
  // The Status to report to the peer in Goodbye: PAYLOAD_TOO_LARGE for size limits (and any
  // chunk before the handshake), RESOURCE_EXHAUSTED for memory budgets, else BAD_ARGUMENTS.
  Status status() const;

 private:
  ProtocolErrorCode code_;
};

// Where a connection's buffered bytes (reassembly buffers, send queue) are counted: its server's
// budgets. Thread-safe.
class BufferBudget {
 public:
  virtual ~BufferBudget() = default;
  // Counts `bytes` more and returns true, or counts nothing and returns false with `why` set to
  // the refusal naming the limit.
  virtual bool take(uint64_t bytes, std::string& why) = 0;
  // Counts `bytes` more whatever the limit (the envelope of what take() admitted).
  virtual void force(uint64_t bytes) = 0;
  virtual void give(uint64_t bytes) = 0;
  virtual uint64_t used() const = 0;
};

// One limit for all connections together (ServerOptions::max_buffered_bytes without fair shares:
// tests, fuzzing). Thread-safe; a check followed by add() may overshoot by what other threads add
// in between (bounded by one frame or piece each).
class MemoryBudget final : public BufferBudget {
 public:
  explicit MemoryBudget(uint64_t limit) : limit_(limit) {}
  MemoryBudget(const MemoryBudget&) = delete;
  MemoryBudget& operator=(const MemoryBudget&) = delete;

  bool fits(uint64_t bytes) const { return used_.load(std::memory_order_relaxed) + bytes <= limit_; }
  void add(uint64_t bytes) { used_.fetch_add(bytes, std::memory_order_relaxed); }
  void release(uint64_t bytes) { used_.fetch_sub(bytes, std::memory_order_relaxed); }
  uint64_t limit() const { return limit_; }

  // BufferBudget
  bool take(uint64_t bytes, std::string& why) override;
  void force(uint64_t bytes) override { add(bytes); }
  void give(uint64_t bytes) override { release(bytes); }
  uint64_t used() const override { return used_.load(std::memory_order_relaxed); }

 private:
  const uint64_t limit_;
  std::atomic<uint64_t> used_{0};
};

struct CodecLimits {
  uint64_t max_frame_bytes = 64u << 10;      // largest single frame after the prefix
  uint64_t max_message_bytes = 64ull << 20;  // largest reassembled (chunked) message
  size_t max_partial_messages = 16;          // chunked messages in progress at once
  // Bytes the buffers of chunked messages in progress may hold together (their capacity).
  uint64_t max_reassembly_bytes = UINT64_MAX;
  // Before the handshake: max_frame_bytes is the Hello limit (named max_hello_bytes in errors)
  // and a Chunk frame is a protocol error (nothing of a declared size is ever allocated).
  bool before_handshake = false;
  // Where this connection's reassembly buffers are counted (null: nowhere).
  std::shared_ptr<BufferBudget> budget;
};

// Splits a byte stream into Frames. Accepts arbitrary slices: a frame may arrive in any number of
// pieces (one byte at a time works) and one slice may hold many frames.
class FrameDecoder {
 public:
  using FrameCallback = std::function<void(Frame&&)>;

  explicit FrameDecoder(uint64_t max_frame_bytes);
  // Before the handshake: the limit is named max_hello_bytes in errors.
  void set_before_handshake(bool before) { before_handshake_ = before; }

  // Consumes all of `bytes`, calling `on_frame` for each complete frame, in order. Throws
  // ProtocolError on an over-limit length (checked before anything is allocated), a zero length,
  // or bytes that do not parse. Exceptions thrown by on_frame propagate.
  void feed(std::string_view bytes, const FrameCallback& on_frame);

  void set_max_frame_bytes(uint64_t max_frame_bytes) { max_frame_bytes_ = max_frame_bytes; }
  uint64_t max_frame_bytes() const { return max_frame_bytes_; }
  // Bytes of an incomplete frame held back (prefix included).
  size_t buffered_bytes() const { return header_have_ + body_.size(); }
  // Frames decoded so far (a transport uses it as a liveness signal).
  uint64_t frames_decoded() const { return frames_decoded_; }

 private:
  void deliver(const char* data, size_t size, const FrameCallback& on_frame);

  uint64_t max_frame_bytes_;
  bool before_handshake_ = false;
  unsigned char header_[kLengthPrefixBytes] = {};
  size_t header_have_ = 0;
  uint64_t expected_ = 0;  // body length once the header is complete
  std::string body_;       // partial body
  uint64_t frames_decoded_ = 0;
};

// Reassembles Chunk frames into the serialized Frame they carry.
class Reassembler {
 public:
  explicit Reassembler(const CodecLimits& limits);
  ~Reassembler();  // hands what it holds back to the budget
  Reassembler(const Reassembler&) = delete;
  Reassembler& operator=(const Reassembler&) = delete;

  // Adds one piece. Returns the serialized Frame when `chunk.last` completes it, else nullopt.
  // Throws ProtocolError if total_bytes exceeds max_message_bytes (before allocating), if more
  // than max_partial_messages would be in progress, if the buffers would grow over
  // max_reassembly_bytes or the shared budget (checked before growing), or if the pieces are
  // inconsistent.
  std::optional<std::string> add(Chunk&& chunk);
  // Hands back the buffer of a message returned by add() once the caller is done with it, so
  // that the next chunked message reuses its memory (already mapped: no page faults) instead of
  // allocating a new one. One buffer of at most kMaxRecycledBytes capacity is kept.
  void recycle(std::string&& buffer);
  static constexpr size_t kMaxRecycledBytes = 4u << 20;

  void set_limits(const CodecLimits& limits);
  size_t partial_messages() const { return partial_.size(); }
  uint64_t buffered_bytes() const { return buffered_bytes_; }
  // Capacity of the buffers of messages in progress (what max_reassembly_bytes bounds).
  uint64_t held_bytes() const { return held_bytes_; }

 private:
  struct Partial {
    uint64_t total = 0;
    std::string data;
    uint64_t accounted = 0;  // of data.capacity(), in held_bytes_ and the budget
  };
  CodecLimits limits_;
  std::map<uint64_t, Partial> partial_;
  // Grows `partial` so that `more` bytes fit, within the limits; keeps held_bytes_ and the budget.
  void grow(Partial& partial, size_t more, const std::string& what);
  void forget(const Partial& partial);

  uint64_t buffered_bytes_ = 0;
  uint64_t held_bytes_ = 0;
  std::string spare_;  // a recycled buffer, empty, for the next message
};

// FrameDecoder + Reassembler: bytes in, complete non-Chunk Frames out.
class MessageDecoder {
 public:
  explicit MessageDecoder(const CodecLimits& limits);

  // Like FrameDecoder::feed, but Chunk frames are reassembled and only whole messages reach
  // `on_message`. Throws ProtocolError (also for a message that does not parse, or a nested Chunk).
  void feed(std::string_view bytes, const FrameDecoder::FrameCallback& on_message);

  void set_limits(const CodecLimits& limits);
  uint64_t frames_decoded() const { return frames_.frames_decoded(); }
  size_t partial_messages() const { return reassembler_.partial_messages(); }

 private:
  bool before_handshake_;
  FrameDecoder frames_;
  Reassembler reassembler_;
};

// Appends the 4-byte big-endian length of `size` to `out`.
void append_length_prefix(std::string& out, uint32_t size);

// Serializes `frame` as one wire frame (prefix included), whatever its size. For tests and for
// handshake frames; traffic goes through the Outbox, which chunks.
std::string encode_frame(const Frame& frame);

// One wire frame as gather-write buffers: `head`, then the byte ranges of `body`, then `tail`.
// The Outbox uses it to send the pieces of a large message straight from the Frame that was
// pushed (no serialized copy of the message, no copy per chunk); `keep` holds the memory that
// `body` points into until the frame has been written.
struct WireFrame {
  std::string head;
  std::vector<std::string_view> body;
  std::string tail;
  std::shared_ptr<const void> keep;

  size_t size() const;
  // The frame as one contiguous string (tests, Outbox::pop()).
  std::string flatten() const;
};

// Turns Frames into wire frames, splitting those above chunk_bytes into Chunk frames.
class FrameEncoder {
 public:
  // Throws std::invalid_argument if chunk_bytes < kMinChunkBytes.
  explicit FrameEncoder(uint32_t chunk_bytes);

  uint32_t chunk_bytes() const { return chunk_bytes_; }
  // Data bytes carried by one Chunk frame.
  size_t piece_bytes() const { return chunk_bytes_ - kChunkOverheadBytes; }

  // All wire frames for `frame`: one if it serializes to at most chunk_bytes, else Chunk frames
  // with `message_id`.
  std::vector<std::string> encode(const Frame& frame, uint64_t message_id) const;
  // One Chunk wire frame with the piece of `message` starting at `offset` (at most piece_bytes()).
  std::string encode_piece(uint64_t message_id, std::string_view message, size_t offset) const;

 private:
  uint32_t chunk_bytes_;
};

namespace detail {
struct SerializedMessage;  // a large Frame serialized as byte ranges (outbox.cpp)
}  // namespace detail

// Outgoing queue of one connection with fair interleaving. Scheduling, per pop():
//  1. priority frames first, in order: small Ping, Pong, Goodbye, Welcome, Refused, Reply,
//     PublishAck, SubscribeAck (answers and heartbeats never wait behind bulk data);
//  2. then the "general" lane (other small frames, in order) and the bulk lanes take turns: one
//     general frame, then one frame or chunk from the next bulk lane in round-robin order.
//     Bulk lanes are: Events (in order, so seq order holds), Publishes (in order), and one lane per
//     other large message (up to max_active_chunked at once; later ones wait their turn).
// So a small call queued behind a 921,600-byte message goes out after at most one chunk.
class Outbox {
 public:
  static constexpr size_t kDefaultMaxActiveChunked = 4;

  explicit Outbox(uint32_t chunk_bytes, size_t max_active_chunked = kDefaultMaxActiveChunked);

  // Serializes and queues `frame`. Returns the serialized size, which is added to queued_bytes().
  size_t push(const Frame& frame);
  // Same, taking ownership: a large frame is then never copied; its chunks are sent straight from
  // its fields (see WireFrame).
  size_t push(Frame&& frame);
  // The next wire frame (prefix included), or nullopt when nothing is queued.
  std::optional<std::string> pop();
  // The same wire frame as pop() would return, as gather buffers (no copy of chunk data).
  std::optional<WireFrame> pop_wire();

  bool empty() const { return queued_frames_ == 0; }
  size_t queued_bytes() const { return queued_bytes_; }
  size_t queued_frames() const { return queued_frames_; }
  void clear();
  // Applies to frames pushed afterwards. Throws std::invalid_argument below kMinChunkBytes.
  void set_chunk_bytes(uint32_t chunk_bytes);

 private:
  struct Entry {
    std::string bytes;                                         // small: whole wire frame
    std::shared_ptr<const detail::SerializedMessage> message;  // chunked: the message to cut
    bool chunked = false;
    uint64_t message_id = 0;
    size_t offset = 0;          // chunked: bytes already sent
    size_t segment = 0;         // chunked: index of the byte range that holds `offset`
    size_t segment_offset = 0;  // chunked: position of `offset` in that range
  };
  using Lane = std::deque<Entry>;

  size_t push_entry(const Frame& frame, std::shared_ptr<const Frame> owned);
  // Pops one wire frame from the head of `lane`; the head is removed once fully sent.
  WireFrame pop_from(Lane& lane);
  Lane* next_bulk_lane();

  FrameEncoder encoder_;
  size_t max_active_chunked_;
  uint64_t next_message_id_ = 1;
  Lane priority_;
  Lane general_;
  Lane events_;
  Lane publishes_;
  std::vector<Lane> active_large_;  // one entry each
  Lane waiting_large_;
  bool general_turn_ = true;
  size_t cursor_ = 0;  // round-robin position among bulk lanes
  size_t queued_bytes_ = 0;
  size_t queued_frames_ = 0;  // Frames (not wire frames) not yet fully popped
};

// Name of the Frame's body ("request", "chunk", ...; "empty" if none), for logs and errors.
std::string_view frame_body_name(const Frame& frame);

}  // namespace urs::planet
