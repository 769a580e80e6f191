// Fuzz entry point for the Planet decoder: arbitrary bytes, fed in slices of a size the input
// chooses, through FrameDecoder + Reassembler (MessageDecoder) with small limits. Anything other
// than a ProtocolError escaping, a crash, or a decoded frame that does not survive a re-encode
// through the Outbox is a bug.
//
// Each input also goes through the server's handshake state machine: Hello limits first (one
// small frame, no chunks), the session's limits once a Hello was decoded, a close at any other
// first frame, all with a shared memory budget. A Chunk reaching the handshake, the budget over
// max_reassembly_bytes, or anything left in the budget once the decoder is gone is a bug.
//
// Input layout: byte 0 picks the slice size (1..64 bytes, or everything at once when 0); the rest
// is the byte stream.

#include <google/protobuf/stubs/logging.h>
#include <google/protobuf/util/message_differencer.h>

#include <cstdint>
#include <cstdlib>
#include <memory>
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

// The server's side of a connection, as far as bytes go: before Welcome, then open.
void run_handshake_state_machine(std::string_view bytes, size_t step) {
  auto budget = std::make_shared<urs::planet::MemoryBudget>(1u << 20);
  CodecLimits open = fuzz_limits();
  open.max_reassembly_bytes = 128 * 1024;
  open.budget = budget;
  CodecLimits hello = open;
  hello.max_frame_bytes = urs::planet::kMinChunkBytes;
  hello.before_handshake = true;
  {
    urs::planet::MessageDecoder decoder(hello);
    bool opened = false;
    bool closed = false;
    try {
      for (size_t offset = 0; offset < bytes.size() && !closed; offset += step) {
        decoder.feed(bytes.substr(offset, step), [&](Frame&& frame) {
          if (closed) return;
          if (!opened) {
            if (frame.has_chunk()) std::abort();  // refused before the handshake, never handed on
            if (!frame.has_hello()) {
              closed = true;  // "expected Hello as the first frame"
              return;
            }
            opened = true;
            decoder.set_limits(open);
            return;
          }
          if (budget->used() > open.max_reassembly_bytes) std::abort();
          check_round_trip(frame);
        });
        if (budget->used() > open.max_reassembly_bytes) std::abort();
      }
    } catch (const urs::planet::ProtocolError&) {
      // The connection would be closed.
    }
  }
  if (budget->used() != 0) std::abort();  // a closed connection holds nothing
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
  run_handshake_state_machine(bytes, step);
  return 0;
}
