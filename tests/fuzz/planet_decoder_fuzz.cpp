// Fuzz entry point for the Planet decoder: arbitrary bytes, fed in slices of a size the input
// chooses, through FrameDecoder + Reassembler (MessageDecoder) with small limits. Anything other
// than a ProtocolError escaping, a crash, or a decoded frame that does not survive a re-encode
// through the Outbox is a bug.
//
// Input layout: byte 0 picks the slice size (1..64 bytes, or everything at once when 0); the rest
// is the byte stream.

#include <google/protobuf/stubs/logging.h>
#include <google/protobuf/util/message_differencer.h>

#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "urs/planet/codec.hpp"

namespace {

using urs::planet::CodecLimits;
using urs::planet::Frame;

CodecLimits fuzz_limits() {
  CodecLimits limits;
  limits.max_frame_bytes = 4096;
  limits.max_message_bytes = 64 * 1024;
  limits.max_partial_messages = 4;
  return limits;
}

// A frame the decoder accepted must come out of Outbox + MessageDecoder unchanged.
void check_round_trip(const Frame& frame) {
  urs::planet::Outbox outbox(urs::planet::kMinChunkBytes);
  outbox.push(frame);
  urs::planet::MessageDecoder decoder(fuzz_limits());
  int count = 0;
  while (auto wire = outbox.pop()) {
    decoder.feed(*wire, [&](Frame&& again) {
      ++count;
      if (!google::protobuf::util::MessageDifferencer::Equals(again, frame)) std::abort();
    });
  }
  if (count != 1) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // Garbage strings make protobuf log "invalid UTF-8" for every input; keep the output readable.
  static const bool quiet = [] {
    google::protobuf::SetLogHandler(nullptr);
    return true;
  }();
  (void)quiet;
  if (size == 0) return 0;
  const size_t step = data[0] % 65 == 0 ? size : data[0] % 65;
  const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  urs::planet::MessageDecoder decoder(fuzz_limits());
  try {
    for (size_t offset = 0; offset < bytes.size(); offset += step) {
      decoder.feed(bytes.substr(offset, step), [](Frame&& frame) { check_round_trip(frame); });
    }
  } catch (const urs::planet::ProtocolError&) {
    // Expected for malformed input: the connection would be closed.
  }
  return 0;
}
