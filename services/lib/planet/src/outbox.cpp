#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream.h>

#include <algorithm>
#include <climits>

#include "codec_detail.hpp"
#include "urs/planet/codec.hpp"

namespace urs::planet {

namespace detail {

// A large Frame queued in an Outbox, serialized as an ordered list of byte ranges: small fields are
// copied into `blocks`, large string/bytes fields (payloads) are referenced where they live in
// `frame` (protobuf "aliasing"). Immutable once built; shared with the WireFrames cut from it.
struct SerializedMessage {
  std::shared_ptr<const Frame> frame;           // owns the aliased bytes
  std::vector<std::unique_ptr<char[]>> blocks;  // owns the copied bytes
  std::string flat;                             // or: the whole serialization, contiguous
  std::vector<std::string_view> segments;       // the serialized Frame, in order
  size_t size = 0;
};

}  // namespace detail

namespace {

using detail::fail;
using detail::n;
using google::protobuf::io::CodedOutputStream;
using google::protobuf::io::ZeroCopyOutputStream;

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
std::shared_ptr<const detail::SerializedMessage> serialize_large(const Frame& frame, std::shared_ptr<const Frame> owned,
                                                                 size_t size) {
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
    out->segments.erase(
        std::remove_if(out->segments.begin(), out->segments.end(), [](std::string_view s) { return s.empty(); }),
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
WireFrame chunk_wire_frame(uint64_t message_id, const std::shared_ptr<const detail::SerializedMessage>& message,
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
  out = chunk_wire_frame(entry.message_id, entry.message, entry.offset, size, entry.segment, entry.segment_offset);
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

}  // namespace urs::planet
