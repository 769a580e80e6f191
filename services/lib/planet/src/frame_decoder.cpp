#include <algorithm>
#include <cstring>

#include "codec_detail.hpp"
#include "urs/planet/codec.hpp"

namespace urs::planet {

using detail::fail;
using detail::n;
using detail::parse_frame;

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
      expected_ = (uint64_t{header_[0]} << 24) | (uint64_t{header_[1]} << 16) | (uint64_t{header_[2]} << 8) |
                  uint64_t{header_[3]};
      if (expected_ == 0) {
        fail(ProtocolErrorCode::kEmptyFrame, "zero-length frame: every frame must carry a serialized urs.planet.Frame");
      }
      // Checked before anything is allocated for the body.
      if (expected_ > max_frame_bytes_ && before_handshake_) {
        fail(ProtocolErrorCode::kFrameTooLarge,
             "frame of " + n(expected_) + " bytes before the handshake exceeds the limit of " + n(max_frame_bytes_) +
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

}  // namespace urs::planet
