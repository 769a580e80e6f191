#include <algorithm>
#include <stdexcept>

#include "codec_detail.hpp"
#include "urs/planet/codec.hpp"

namespace urs::planet {

using detail::fail;
using detail::n;

void append_length_prefix(std::string& out, uint32_t size) {
  out.push_back(static_cast<char>((size >> 24) & 0xff));
  out.push_back(static_cast<char>((size >> 16) & 0xff));
  out.push_back(static_cast<char>((size >> 8) & 0xff));
  out.push_back(static_cast<char>(size & 0xff));
}

std::string encode_frame(const Frame& frame) {
  const size_t size = frame.ByteSizeLong();
  if (size > UINT32_MAX) {
    fail(ProtocolErrorCode::kFrameTooLarge, "frame of " + n(size) + " bytes cannot be framed (over 4 GiB); chunk it");
  }
  std::string out;
  out.reserve(kLengthPrefixBytes + size);
  append_length_prefix(out, static_cast<uint32_t>(size));
  frame.AppendToString(&out);
  return out;
}

FrameEncoder::FrameEncoder(uint32_t chunk_bytes) : chunk_bytes_(chunk_bytes) {
  if (chunk_bytes < kMinChunkBytes) {
    throw std::invalid_argument("chunk_bytes " + n(chunk_bytes) + " is below the minimum of " + n(kMinChunkBytes));
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

std::string FrameEncoder::encode_piece(uint64_t message_id, std::string_view message, size_t offset) const {
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

}  // namespace urs::planet
