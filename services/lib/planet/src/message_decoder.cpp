#include "codec_detail.hpp"
#include "urs/planet/codec.hpp"

namespace urs::planet {

using detail::fail;
using detail::n;
using detail::parse_frame;

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
           "a Chunk frame before the handshake: only one un-chunked Hello of at most " + n(frames_.max_frame_bytes()) +
               " bytes (max_hello_bytes) may be sent before Welcome");
    }
    const uint64_t id = frame.chunk().message_id();
    std::optional<std::string> whole = reassembler_.add(std::move(*frame.mutable_chunk()));
    if (!whole) return;
    Frame message;
    parse_frame(whole->data(), whole->size(), message, ("reassembled message " + n(id)).c_str());
    reassembler_.recycle(std::move(*whole));
    if (message.has_chunk()) {
      fail(ProtocolErrorCode::kNestedChunk, "reassembled message " + n(id) + " is itself a Chunk; chunks do not nest");
    }
    on_message(std::move(message));
  });
}

}  // namespace urs::planet
