#include "urs/planet/codec.hpp"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream.h>

#include <algorithm>
#include <climits>
#include <cstring>

namespace urs::planet {

namespace detail {

// A large Frame queued in an Outbox, serialized as an ordered list of byte ranges: small fields are
// copied into `blocks`, large string/bytes fields (payloads) are referenced where they live in
// `frame` (protobuf "aliasing"). Immutable once built; shared with the WireFrames cut from it.
struct SerializedMessage {
  std::shared_ptr<const Frame> frame;          // owns the aliased bytes
  std::vector<std::unique_ptr<char[]>> blocks;  // owns the copied bytes
  std::string flat;                             // or: the whole serialization, contiguous
  std::vector<std::string_view> segments;       // the serialized Frame, in order
  size_t size = 0;
};

}  // namespace detail

namespace {

// Initial buffer for a chunked message: its size is declared by the peer, so reserve at most this
// much up front and let the buffer grow with the data that actually arrives.
constexpr uint64_t kInitialReassemblyReserve = 1u << 20;

using google::protobuf::io::CodedOutputStream;
using google::protobuf::io::ZeroCopyOutputStream;

std::string n(uint64_t value) { return std::to_string(value); }

[[noreturn]] void fail(ProtocolErrorCode code, const std::string& message) {
  throw ProtocolError(code, message);
}

bool is_priority(const Frame& frame) {
  switch (frame.body_case()) {
    case Frame::kPing:
    case Frame::kPong:
    case Frame::kGoodbye:
    case Frame::kWelcome:
    case Frame::kRefused:
    case Frame::kReply:
    case Frame::kPublishAck:
    case Frame::kSubscribeAck:
      return true;
    default:
      return false;
  }
}

void parse_frame(const char* data, size_t size, Frame& frame, const char* what) {
  if (!frame.ParseFromArray(data, static_cast<int>(size))) {
    fail(ProtocolErrorCode::kMalformedFrame,
         std::string(what) + " of " + n(size) + " bytes does not parse as a urs.planet.Frame");
  }
  if (frame.body_case() == Frame::BODY_NOT_SET) {
    fail(ProtocolErrorCode::kMalformedFrame,
         std::string(what) + " of " + n(size) +
             " bytes has no known body (a frame type of a newer protocol version?)");
  }
}

// Collects a serialization as byte ranges, referencing (not copying) the large fields.
class SegmentOutputStream final : public ZeroCopyOutputStream {
 public:
  explicit SegmentOutputStream(detail::SerializedMessage& out) : out_(out) {}

  bool Next(void** data, int* size) override {
    out_.blocks.push_back(std::make_unique<char[]>(kBlockBytes));
    char* block = out_.blocks.back().get();
    out_.segments.emplace_back(block, kBlockBytes);
    last_block_ = out_.segments.size() - 1;
    bytes_ += kBlockBytes;
    *data = block;
    *size = static_cast<int>(kBlockBytes);
    return true;
  }
  void BackUp(int count) override {
    if (count <= 0) return;
    // Protobuf only backs up the buffer of the last Next(), before anything else is written.
    std::string_view& block = out_.segments[last_block_];
    block = std::string_view(block.data(), block.size() - static_cast<size_t>(count));
    bytes_ -= count;
  }
  int64_t ByteCount() const override { return bytes_; }
  bool AllowsAliasing() const override { return true; }
  bool WriteAliasedRaw(const void* data, int size) override {
    if (size > 0) out_.segments.emplace_back(static_cast<const char*>(data), size);
    bytes_ += size;
    return true;
  }

 private:
  // Fields shorter than what is left of a block are copied; longer ones are referenced.
  static constexpr size_t kBlockBytes = 1024;
  detail::SerializedMessage& out_;
  size_t last_block_ = 0;
  int64_t bytes_ = 0;
};

// Serializes a large frame for the Outbox: by reference into `owned` when the Outbox owns the
// frame, else as one contiguous copy.
std::shared_ptr<const detail::SerializedMessage> serialize_large(
    const Frame& frame, std::shared_ptr<const Frame> owned, size_t size) {
  auto out = std::make_shared<detail::SerializedMessage>();
  out->size = size;
  if (owned && size <= static_cast<size_t>(INT_MAX)) {
    bool failed = false;
    {
      SegmentOutputStream stream(*out);
      CodedOutputStream coded(&stream);
      coded.EnableAliasing(true);
      frame.SerializeWithCachedSizes(&coded);  // sizes cached by the caller's ByteSizeLong()
      coded.Trim();
      failed = coded.HadError();
    }
    size_t total = 0;
    out->segments.erase(std::remove_if(out->segments.begin(), out->segments.end(),
                                       [](std::string_view s) { return s.empty(); }),
                        out->segments.end());
    for (std::string_view segment : out->segments) total += segment.size();
    if (!failed && total == size) {
      out->frame = std::move(owned);
      return out;
    }
    out->segments.clear();  // cannot happen; fall back to a contiguous copy
    out->blocks.clear();
  }
  out->flat = frame.SerializeAsString();
  if (out->flat.size() != size) {
    fail(ProtocolErrorCode::kFrameTooLarge,
         "frame of " + n(size) + " bytes cannot be serialized (protobuf's limit is 2 GiB)");
  }
  out->segments.emplace_back(out->flat);
  return out;
}

size_t varint_size(uint64_t value) {
  size_t size = 1;
  while (value >= 0x80) {
    value >>= 7;
    ++size;
  }
  return size;
}

void append_varint(std::string& out, uint64_t value) {
  while (value >= 0x80) {
    out.push_back(static_cast<char>((value & 0x7f) | 0x80));
    value >>= 7;
  }
  out.push_back(static_cast<char>(value));
}

// Protobuf keys (field number << 3 | wire type) of the Chunk fields, and of Frame.chunk.
constexpr char kFrameChunkKey = (Frame::kChunkFieldNumber << 3) | 2;
constexpr char kMessageIdKey = (Chunk::kMessageIdFieldNumber << 3) | 0;
constexpr char kTotalBytesKey = (Chunk::kTotalBytesFieldNumber << 3) | 0;
constexpr char kDataKey = (Chunk::kDataFieldNumber << 3) | 2;
constexpr char kLastKey = (Chunk::kLastFieldNumber << 3) | 0;
constexpr char kOffsetKey = (Chunk::kOffsetFieldNumber << 3) | 0;

// The wire frame of one piece of `message`: exactly the bytes encode_piece() produces (the
// canonical serialization of the Chunk frame), with the data referenced instead of copied.
// `segment` / `segment_offset` locate `offset` in message.segments and are advanced past the piece.
WireFrame chunk_wire_frame(uint64_t message_id,
                           const std::shared_ptr<const detail::SerializedMessage>& message,
                           size_t offset, size_t size, size_t& segment, size_t& segment_offset) {
  const uint64_t total = message->size;
  const bool last = offset + size == total;
  size_t chunk_size = 0;
  if (message_id != 0) chunk_size += 1 + varint_size(message_id);
  chunk_size += 1 + varint_size(total);
  chunk_size += 1 + varint_size(size) + size;
  if (last) chunk_size += 2;
  if (offset != 0) chunk_size += 1 + varint_size(offset);
  const size_t frame_size = 1 + varint_size(chunk_size) + chunk_size;

  WireFrame wire;
  wire.head.reserve(kLengthPrefixBytes + 40);
  append_length_prefix(wire.head, static_cast<uint32_t>(frame_size));
  wire.head.push_back(kFrameChunkKey);
  append_varint(wire.head, chunk_size);
  if (message_id != 0) {
    wire.head.push_back(kMessageIdKey);
    append_varint(wire.head, message_id);
  }
  wire.head.push_back(kTotalBytesKey);
  append_varint(wire.head, total);
  wire.head.push_back(kDataKey);
  append_varint(wire.head, size);
  size_t left = size;
  while (left > 0) {
    const std::string_view range = message->segments[segment];
    const size_t take = std::min(left, range.size() - segment_offset);
    wire.body.push_back(range.substr(segment_offset, take));
    left -= take;
    segment_offset += take;
    if (segment_offset == range.size()) {
      ++segment;
      segment_offset = 0;
    }
  }
  if (last) {
    wire.tail.push_back(kLastKey);
    wire.tail.push_back(1);
  }
  if (offset != 0) {
    wire.tail.push_back(kOffsetKey);
    append_varint(wire.tail, offset);
  }
  wire.keep = message;
  return wire;
}

}  // namespace

size_t WireFrame::size() const {
  size_t total = head.size() + tail.size();
  for (std::string_view range : body) total += range.size();
  return total;
}

std::string WireFrame::flatten() const {
  std::string out;
  out.reserve(size());
  out += head;
  for (std::string_view range : body) out.append(range.data(), range.size());
  out += tail;
  return out;
}

std::string_view protocol_error_name(ProtocolErrorCode code) {
  switch (code) {
    case ProtocolErrorCode::kFrameTooLarge: return "FRAME_TOO_LARGE";
    case ProtocolErrorCode::kEmptyFrame: return "EMPTY_FRAME";
    case ProtocolErrorCode::kMalformedFrame: return "MALFORMED_FRAME";
    case ProtocolErrorCode::kMessageTooLarge: return "MESSAGE_TOO_LARGE";
    case ProtocolErrorCode::kTooManyPartialMessages: return "TOO_MANY_PARTIAL_MESSAGES";
    case ProtocolErrorCode::kInconsistentChunk: return "INCONSISTENT_CHUNK";
    case ProtocolErrorCode::kUnknownChunk: return "UNKNOWN_CHUNK";
    case ProtocolErrorCode::kChunkOverflow: return "CHUNK_OVERFLOW";
    case ProtocolErrorCode::kNestedChunk: return "NESTED_CHUNK";
    case ProtocolErrorCode::kChunkBeforeHandshake: return "CHUNK_BEFORE_HANDSHAKE";
    case ProtocolErrorCode::kReassemblyLimit: return "REASSEMBLY_LIMIT";
    case ProtocolErrorCode::kServerBudget: return "SERVER_BUDGET";
  }
  return "UNKNOWN_PROTOCOL_ERROR";
}

ProtocolError::ProtocolError(ProtocolErrorCode code, const std::string& message)
    : std::runtime_error(message), code_(code) {}

Status ProtocolError::status() const {
  switch (code_) {
    case ProtocolErrorCode::kFrameTooLarge:
    case ProtocolErrorCode::kMessageTooLarge:
    case ProtocolErrorCode::kChunkBeforeHandshake:
      return Status::PAYLOAD_TOO_LARGE;
    case ProtocolErrorCode::kReassemblyLimit:
    case ProtocolErrorCode::kServerBudget:
      return Status::RESOURCE_EXHAUSTED;
    default:
      return Status::BAD_ARGUMENTS;
  }
}

std::string_view frame_body_name(const Frame& frame) {
  switch (frame.body_case()) {
    case Frame::kHello: return "hello";
    case Frame::kWelcome: return "welcome";
    case Frame::kRefused: return "refused";
    case Frame::kRequest: return "request";
    case Frame::kReply: return "reply";
    case Frame::kPublish: return "publish";
    case Frame::kPublishAck: return "publish_ack";
    case Frame::kSubscribe: return "subscribe";
    case Frame::kSubscribeAck: return "subscribe_ack";
    case Frame::kUnsubscribe: return "unsubscribe";
    case Frame::kEvent: return "event";
    case Frame::kPing: return "ping";
    case Frame::kPong: return "pong";
    case Frame::kChunk: return "chunk";
    case Frame::kGoodbye: return "goodbye";
    case Frame::BODY_NOT_SET: break;
  }
  return "empty";
}

// ---- FrameDecoder -------------------------------------------------------------------------------

FrameDecoder::FrameDecoder(uint64_t max_frame_bytes) : max_frame_bytes_(max_frame_bytes) {}

void FrameDecoder::feed(std::string_view bytes, const FrameCallback& on_frame) {
  const char* p = bytes.data();
  size_t left = bytes.size();
  while (left > 0) {
    if (header_have_ < kLengthPrefixBytes) {
      size_t take = std::min(kLengthPrefixBytes - header_have_, left);
      std::memcpy(header_ + header_have_, p, take);
      header_have_ += take;
      p += take;
      left -= take;
      if (header_have_ < kLengthPrefixBytes) return;
      expected_ = (uint64_t{header_[0]} << 24) | (uint64_t{header_[1]} << 16) |
                  (uint64_t{header_[2]} << 8) | uint64_t{header_[3]};
      if (expected_ == 0) {
        fail(ProtocolErrorCode::kEmptyFrame,
             "zero-length frame: every frame must carry a serialized urs.planet.Frame");
      }
      // Checked before anything is allocated for the body.
      if (expected_ > max_frame_bytes_ && before_handshake_) {
        fail(ProtocolErrorCode::kFrameTooLarge,
             "frame of " + n(expected_) + " bytes before the handshake exceeds the limit of " +
                 n(max_frame_bytes_) +
                 " bytes (max_hello_bytes): only one un-chunked Hello of at most that size may be "
                 "sent before Welcome");
      }
      if (expected_ > max_frame_bytes_) {
        fail(ProtocolErrorCode::kFrameTooLarge,
             "frame of " + n(expected_) + " bytes exceeds the limit of " + n(max_frame_bytes_) +
                 " bytes (max_frame_bytes); the sender must split larger messages into Chunk "
                 "frames, or raise the receiver's chunk_bytes (ServerOptions::chunk_bytes / "
                 "ClientOptions::chunk_bytes)");
      }
    }
    if (body_.empty() && left >= expected_) {
      // Whole frame in this slice: parse in place, no copy.
      const char* frame = p;
      size_t size = static_cast<size_t>(expected_);
      p += size;
      left -= size;
      header_have_ = 0;
      expected_ = 0;
      deliver(frame, size, on_frame);
      continue;
    }
    if (body_.empty()) body_.reserve(static_cast<size_t>(expected_));
    size_t take = std::min(static_cast<size_t>(expected_) - body_.size(), left);
    body_.append(p, take);
    p += take;
    left -= take;
    if (body_.size() == expected_) {
      // Parsed before the callback, so body_ keeps its memory for the next frame.
      Frame frame;
      parse_frame(body_.data(), body_.size(), frame, "frame");
      body_.clear();
      header_have_ = 0;
      expected_ = 0;
      ++frames_decoded_;
      on_frame(std::move(frame));
    }
  }
}

void FrameDecoder::deliver(const char* data, size_t size, const FrameCallback& on_frame) {
  Frame frame;
  parse_frame(data, size, frame, "frame");
  ++frames_decoded_;
  on_frame(std::move(frame));
}

// ---- Reassembler --------------------------------------------------------------------------------

Reassembler::Reassembler(const CodecLimits& limits) : limits_(limits) {}

std::optional<std::string> Reassembler::add(Chunk&& chunk) {
  const uint64_t id = chunk.message_id();
  const uint64_t total = chunk.total_bytes();
  const uint64_t offset = chunk.offset();
  const std::string& data = chunk.data();
  const std::string what = "chunked message " + n(id);

  if (total == 0) {
    fail(ProtocolErrorCode::kInconsistentChunk, what + " declares total_bytes 0");
  }
  if (total > limits_.max_message_bytes) {
    fail(ProtocolErrorCode::kMessageTooLarge,
         what + " of " + n(total) + " bytes exceeds the limit of " + n(limits_.max_message_bytes) +
             " bytes (max_message_bytes); send less per message or raise the receiver's "
             "max_message_bytes (ServerOptions::max_message_bytes / "
             "ClientOptions::max_message_bytes)");
  }
  if (data.empty()) {
    fail(ProtocolErrorCode::kInconsistentChunk,
         what + ": the piece at offset " + n(offset) + " carries no data");
  }

  auto it = partial_.find(id);
  if (it == partial_.end()) {
    if (offset != 0) {
      fail(ProtocolErrorCode::kUnknownChunk,
           what + ": piece at offset " + n(offset) +
               " of a message that was never started (its first piece, at offset 0, is missing)");
    }
    if (data.size() > total) {
      fail(ProtocolErrorCode::kChunkOverflow, what + ": a piece of " + n(data.size()) +
                                                  " bytes exceeds total_bytes " + n(total));
    }
    if (data.size() == total) {
      if (!chunk.last()) {
        fail(ProtocolErrorCode::kInconsistentChunk,
             what + " reached total_bytes " + n(total) + " in a piece not marked last");
      }
      return std::move(*chunk.mutable_data());
    }
    if (chunk.last()) {
      fail(ProtocolErrorCode::kInconsistentChunk,
           what + ": the last piece ends at " + n(data.size()) + " of " + n(total) + " bytes");
    }
    if (partial_.size() >= limits_.max_partial_messages) {
      fail(ProtocolErrorCode::kTooManyPartialMessages,
           what + " would be one more chunked message in progress than the limit of " +
               n(limits_.max_partial_messages) +
               " (max_partial_messages); a sender must finish messages before starting more");
    }
    Partial& partial = partial_[id];
    partial.total = total;
    partial.data.swap(spare_);  // reuse the recycled buffer, if any (already held: counted as is)
    partial.accounted = partial.data.capacity();
    held_bytes_ += partial.accounted;
    if (limits_.budget) limits_.budget->add(partial.accounted);
    try {
      grow(partial, data.size(), what);
    } catch (const ProtocolError&) {
      forget(partial);
      partial_.erase(id);
      throw;
    }
    partial.data.append(data);
    buffered_bytes_ += data.size();
    return std::nullopt;
  }

  Partial& partial = it->second;
  if (total != partial.total) {
    fail(ProtocolErrorCode::kInconsistentChunk,
         what + ": total_bytes changed from " + n(partial.total) + " to " + n(total));
  }
  if (offset != partial.data.size()) {
    fail(ProtocolErrorCode::kInconsistentChunk,
         what + ": piece at offset " + n(offset) + ", expected offset " + n(partial.data.size()));
  }
  if (data.size() > total - partial.data.size()) {
    fail(ProtocolErrorCode::kChunkOverflow,
         what + ": pieces add up to " + n(partial.data.size() + data.size()) +
             " bytes, more than total_bytes " + n(total));
  }
  const bool complete = partial.data.size() + data.size() == total;
  if (complete != chunk.last()) {
    fail(ProtocolErrorCode::kInconsistentChunk,
         complete ? what + " reached total_bytes " + n(total) + " in a piece not marked last"
                  : what + ": the last piece ends at " + n(partial.data.size() + data.size()) +
                        " of " + n(total) + " bytes");
  }
  grow(partial, data.size(), what);
  partial.data.append(data);
  buffered_bytes_ += data.size();
  if (!complete) return std::nullopt;
  std::string message = std::move(partial.data);
  buffered_bytes_ -= message.size();
  forget(partial);
  partial_.erase(it);
  return message;
}

Reassembler::~Reassembler() {
  for (const auto& [id, partial] : partial_) forget(partial);
}

void Reassembler::set_limits(const CodecLimits& limits) {
  if (limits.budget != limits_.budget && held_bytes_ > 0) {
    if (limits_.budget) limits_.budget->release(held_bytes_);
    if (limits.budget) limits.budget->add(held_bytes_);
  }
  limits_ = limits;
}

void Reassembler::grow(Partial& partial, size_t more, const std::string& what) {
  const uint64_t need = partial.data.size() + more;  // never above total (checked by the caller)
  const uint64_t capacity = partial.data.capacity();
  if (need <= capacity) return;
  // The size is declared by the peer: start at kInitialReassemblyReserve at most and grow with
  // the data that actually arrives (doubling, never beyond total).
  const uint64_t target =
      std::max(need, std::min(partial.total, std::max(2 * capacity, kInitialReassemblyReserve)));
  const uint64_t extra = target - capacity;
  if (held_bytes_ + extra > limits_.max_reassembly_bytes) {
    fail(ProtocolErrorCode::kReassemblyLimit,
         what + ": the chunked messages in progress on this connection would hold " +
             n(held_bytes_ + extra) + " bytes, more than the limit of " +
             n(limits_.max_reassembly_bytes) +
             " bytes (max_reassembly_bytes); finish messages before starting more, or raise the "
             "receiver's max_reassembly_bytes");
  }
  if (limits_.budget && !limits_.budget->fits(extra)) {
    fail(ProtocolErrorCode::kServerBudget,
         what + ": the server's buffers for all connections hold " + n(limits_.budget->used()) +
             " bytes; " + n(extra) + " more would exceed the limit of " +
             n(limits_.budget->limit()) + " bytes (max_buffered_bytes); retry later");
  }
  partial.data.reserve(static_cast<size_t>(target));
  const uint64_t grown = partial.data.capacity() - partial.accounted;
  partial.accounted += grown;
  held_bytes_ += grown;
  if (limits_.budget) limits_.budget->add(grown);
}

void Reassembler::forget(const Partial& partial) {
  held_bytes_ -= partial.accounted;
  if (limits_.budget) limits_.budget->release(partial.accounted);
}

void Reassembler::recycle(std::string&& buffer) {
  if (buffer.capacity() > kMaxRecycledBytes || buffer.capacity() <= spare_.capacity()) return;
  buffer.clear();
  spare_ = std::move(buffer);
}

// ---- MessageDecoder -----------------------------------------------------------------------------

MessageDecoder::MessageDecoder(const CodecLimits& limits)
    : before_handshake_(limits.before_handshake), frames_(limits.max_frame_bytes), reassembler_(limits) {
  frames_.set_before_handshake(before_handshake_);
}

void MessageDecoder::set_limits(const CodecLimits& limits) {
  before_handshake_ = limits.before_handshake;
  frames_.set_max_frame_bytes(limits.max_frame_bytes);
  frames_.set_before_handshake(before_handshake_);
  reassembler_.set_limits(limits);
}

void MessageDecoder::feed(std::string_view bytes, const FrameDecoder::FrameCallback& on_message) {
  frames_.feed(bytes, [&](Frame&& frame) {
    if (!frame.has_chunk()) {
      on_message(std::move(frame));
      return;
    }
    if (before_handshake_) {
      fail(ProtocolErrorCode::kChunkBeforeHandshake,
           "a Chunk frame before the handshake: only one un-chunked Hello of at most " +
               n(frames_.max_frame_bytes()) + " bytes (max_hello_bytes) may be sent before Welcome");
    }
    const uint64_t id = frame.chunk().message_id();
    std::optional<std::string> whole = reassembler_.add(std::move(*frame.mutable_chunk()));
    if (!whole) return;
    Frame message;
    parse_frame(whole->data(), whole->size(), message,
                ("reassembled message " + n(id)).c_str());
    reassembler_.recycle(std::move(*whole));
    if (message.has_chunk()) {
      fail(ProtocolErrorCode::kNestedChunk,
           "reassembled message " + n(id) + " is itself a Chunk; chunks do not nest");
    }
    on_message(std::move(message));
  });
}

// ---- Encoding -----------------------------------------------------------------------------------

void append_length_prefix(std::string& out, uint32_t size) {
  out.push_back(static_cast<char>((size >> 24) & 0xff));
  out.push_back(static_cast<char>((size >> 16) & 0xff));
  out.push_back(static_cast<char>((size >> 8) & 0xff));
  out.push_back(static_cast<char>(size & 0xff));
}

std::string encode_frame(const Frame& frame) {
  const size_t size = frame.ByteSizeLong();
  if (size > UINT32_MAX) {
    fail(ProtocolErrorCode::kFrameTooLarge,
         "frame of " + n(size) + " bytes cannot be framed (over 4 GiB); chunk it");
  }
  std::string out;
  out.reserve(kLengthPrefixBytes + size);
  append_length_prefix(out, static_cast<uint32_t>(size));
  frame.AppendToString(&out);
  return out;
}

FrameEncoder::FrameEncoder(uint32_t chunk_bytes) : chunk_bytes_(chunk_bytes) {
  if (chunk_bytes < kMinChunkBytes) {
    throw std::invalid_argument("chunk_bytes " + n(chunk_bytes) + " is below the minimum of " +
                                n(kMinChunkBytes));
  }
}

std::vector<std::string> FrameEncoder::encode(const Frame& frame, uint64_t message_id) const {
  std::vector<std::string> out;
  if (frame.ByteSizeLong() <= chunk_bytes_) {
    out.push_back(encode_frame(frame));
    return out;
  }
  const std::string message = frame.SerializeAsString();
  for (size_t offset = 0; offset < message.size(); offset += piece_bytes()) {
    out.push_back(encode_piece(message_id, message, offset));
  }
  return out;
}

std::string FrameEncoder::encode_piece(uint64_t message_id, std::string_view message,
                                       size_t offset) const {
  const size_t size = std::min(piece_bytes(), message.size() - offset);
  Frame frame;
  Chunk* chunk = frame.mutable_chunk();
  chunk->set_message_id(message_id);
  chunk->set_total_bytes(message.size());
  chunk->set_offset(offset);
  chunk->set_data(message.data() + offset, size);
  chunk->set_last(offset + size == message.size());
  return encode_frame(frame);
}

// ---- Outbox -------------------------------------------------------------------------------------

Outbox::Outbox(uint32_t chunk_bytes, size_t max_active_chunked)
    : encoder_(chunk_bytes), max_active_chunked_(std::max<size_t>(1, max_active_chunked)) {}

void Outbox::set_chunk_bytes(uint32_t chunk_bytes) { encoder_ = FrameEncoder(chunk_bytes); }

size_t Outbox::push(const Frame& frame) { return push_entry(frame, nullptr); }

size_t Outbox::push(Frame&& frame) {
  if (frame.ByteSizeLong() <= encoder_.chunk_bytes()) return push_entry(frame, nullptr);
  auto owned = std::make_shared<const Frame>(std::move(frame));
  return push_entry(*owned, owned);
}

size_t Outbox::push_entry(const Frame& frame, std::shared_ptr<const Frame> owned) {
  const size_t size = frame.ByteSizeLong();
  Entry entry;
  Lane* lane = nullptr;
  const bool event = frame.has_event();
  const bool publish = frame.has_publish();
  if (size <= encoder_.chunk_bytes()) {
    entry.bytes = encode_frame(frame);
    lane = is_priority(frame) ? &priority_ : event ? &events_ : publish ? &publishes_ : &general_;
  } else {
    entry.chunked = true;
    entry.message = serialize_large(frame, std::move(owned), size);
    entry.message_id = next_message_id_++;
    if (event) {
      lane = &events_;
    } else if (publish) {
      lane = &publishes_;
    } else if (active_large_.size() < max_active_chunked_) {
      active_large_.emplace_back();
      lane = &active_large_.back();
    } else {
      lane = &waiting_large_;
    }
  }
  lane->push_back(std::move(entry));
  queued_bytes_ += size;
  ++queued_frames_;
  return size;
}

WireFrame Outbox::pop_from(Lane& lane) {
  Entry& entry = lane.front();
  WireFrame out;
  if (!entry.chunked) {
    out.head = std::move(entry.bytes);
    queued_bytes_ -= out.head.size() - kLengthPrefixBytes;
    --queued_frames_;
    lane.pop_front();
    return out;
  }
  const size_t total = entry.message->size;
  const size_t size = std::min(encoder_.piece_bytes(), total - entry.offset);
  out = chunk_wire_frame(entry.message_id, entry.message, entry.offset, size, entry.segment,
                         entry.segment_offset);
  entry.offset += size;
  queued_bytes_ -= size;
  if (entry.offset == total) {
    --queued_frames_;
    lane.pop_front();
  }
  return out;
}

Outbox::Lane* Outbox::next_bulk_lane() {
  const size_t count = 2 + active_large_.size();
  for (size_t k = 0; k < count; ++k) {
    const size_t index = (cursor_ + k) % count;
    Lane& lane = index == 0 ? events_ : index == 1 ? publishes_ : active_large_[index - 2];
    if (!lane.empty()) {
      cursor_ = index + 1;
      return &lane;
    }
  }
  return nullptr;
}

std::optional<std::string> Outbox::pop() {
  std::optional<WireFrame> wire = pop_wire();
  if (!wire) return std::nullopt;
  if (wire->body.empty() && wire->tail.empty()) return std::move(wire->head);
  return wire->flatten();
}

std::optional<WireFrame> Outbox::pop_wire() {
  if (!priority_.empty()) return pop_from(priority_);
  if (general_turn_ && !general_.empty()) {
    general_turn_ = false;
    return pop_from(general_);
  }
  if (Lane* lane = next_bulk_lane()) {
    WireFrame out = pop_from(*lane);
    general_turn_ = true;
    // Retire finished large-message lanes and start waiting messages in their place.
    for (size_t i = 0; i < active_large_.size();) {
      if (active_large_[i].empty()) {
        active_large_.erase(active_large_.begin() + static_cast<std::ptrdiff_t>(i));
        if (cursor_ > i + 2) --cursor_;
      } else {
        ++i;
      }
    }
    while (active_large_.size() < max_active_chunked_ && !waiting_large_.empty()) {
      active_large_.emplace_back();
      active_large_.back().push_back(std::move(waiting_large_.front()));
      waiting_large_.pop_front();
    }
    return out;
  }
  if (!general_.empty()) return pop_from(general_);
  return std::nullopt;
}

void Outbox::clear() {
  priority_.clear();
  general_.clear();
  events_.clear();
  publishes_.clear();
  active_large_.clear();
  waiting_large_.clear();
  general_turn_ = true;
  cursor_ = 0;
  queued_bytes_ = 0;
  queued_frames_ = 0;
}

void check_message_limits(uint32_t chunk_bytes, uint64_t max_message_bytes, std::vector<std::string>& errors) {
  if (chunk_bytes < kMinChunkBytes) {
    errors.push_back("chunk_bytes " + std::to_string(chunk_bytes) + " is below the minimum " +
                     std::to_string(kMinChunkBytes));
  }
  if (max_message_bytes < chunk_bytes || max_message_bytes > kMaxMessageBytesCeiling) {
    errors.push_back("max_message_bytes " + std::to_string(max_message_bytes) + " must be between chunk_bytes (" +
                     std::to_string(chunk_bytes) + ") and " + std::to_string(kMaxMessageBytesCeiling));
  }
}

}  // namespace urs::planet
