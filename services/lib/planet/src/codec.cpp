#include "urs/planet/codec.hpp"

#include <string>
#include <vector>

#include "codec_detail.hpp"

namespace urs::planet {

namespace detail {

std::string n(uint64_t value) { return std::to_string(value); }

[[noreturn]] void fail(ProtocolErrorCode code, const std::string& message) { throw ProtocolError(code, message); }

void parse_frame(const char* data, size_t size, Frame& frame, const char* what) {
  if (!frame.ParseFromArray(data, static_cast<int>(size))) {
    fail(ProtocolErrorCode::kMalformedFrame,
         std::string(what) + " of " + n(size) + " bytes does not parse as a urs.planet.Frame");
  }
  if (frame.body_case() == Frame::BODY_NOT_SET) {
    fail(ProtocolErrorCode::kMalformedFrame,
         std::string(what) + " of " + n(size) + " bytes has no known body (a frame type of a newer protocol version?)");
  }
}

}  // namespace detail

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

bool MemoryBudget::take(uint64_t bytes, std::string& why) {
  if (!fits(bytes)) {
    why = "the buffers of all connections hold " + std::to_string(used()) + " bytes; " + std::to_string(bytes) +
          " more would exceed the limit of " + std::to_string(limit_) + " bytes (max_buffered_bytes); retry later";
    return false;
  }
  add(bytes);
  return true;
}

std::string_view protocol_error_name(ProtocolErrorCode code) {
  switch (code) {
    case ProtocolErrorCode::kFrameTooLarge:
      return "FRAME_TOO_LARGE";
    case ProtocolErrorCode::kEmptyFrame:
      return "EMPTY_FRAME";
    case ProtocolErrorCode::kMalformedFrame:
      return "MALFORMED_FRAME";
    case ProtocolErrorCode::kMessageTooLarge:
      return "MESSAGE_TOO_LARGE";
    case ProtocolErrorCode::kTooManyPartialMessages:
      return "TOO_MANY_PARTIAL_MESSAGES";
    case ProtocolErrorCode::kInconsistentChunk:
      return "INCONSISTENT_CHUNK";
    case ProtocolErrorCode::kUnknownChunk:
      return "UNKNOWN_CHUNK";
    case ProtocolErrorCode::kChunkOverflow:
      return "CHUNK_OVERFLOW";
    case ProtocolErrorCode::kNestedChunk:
      return "NESTED_CHUNK";
    case ProtocolErrorCode::kChunkBeforeHandshake:
      return "CHUNK_BEFORE_HANDSHAKE";
    case ProtocolErrorCode::kReassemblyLimit:
      return "REASSEMBLY_LIMIT";
    case ProtocolErrorCode::kServerBudget:
      return "SERVER_BUDGET";
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
    case Frame::kHello:
      return "hello";
    case Frame::kWelcome:
      return "welcome";
    case Frame::kRefused:
      return "refused";
    case Frame::kRequest:
      return "request";
    case Frame::kReply:
      return "reply";
    case Frame::kPublish:
      return "publish";
    case Frame::kPublishAck:
      return "publish_ack";
    case Frame::kSubscribe:
      return "subscribe";
    case Frame::kSubscribeAck:
      return "subscribe_ack";
    case Frame::kUnsubscribe:
      return "unsubscribe";
    case Frame::kEvent:
      return "event";
    case Frame::kPing:
      return "ping";
    case Frame::kPong:
      return "pong";
    case Frame::kChunk:
      return "chunk";
    case Frame::kGoodbye:
      return "goodbye";
    case Frame::BODY_NOT_SET:
      break;
  }
  return "empty";
}

}  // namespace urs::planet
