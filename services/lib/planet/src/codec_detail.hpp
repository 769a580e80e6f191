#pragma once
// What the parts of the Planet codec (urs/planet/codec.hpp; codec.cpp, frame_decoder.cpp,
// reassembler.cpp, message_decoder.cpp, frame_encoder.cpp, outbox.cpp) share: raising a
// ProtocolError, parsing one Frame with the codec's checks, and numbers in its messages.
// Functions of their arguments only: any thread.

#include <cstddef>
#include <cstdint>
#include <string>

#include "urs/planet/codec.hpp"

namespace urs::planet::detail {

// A number in an error message.
std::string n(uint64_t value);

[[noreturn]] void fail(ProtocolErrorCode code, const std::string& message);

// Parses `size` bytes as one Frame into `frame`; throws ProtocolError (kMalformedFrame) if they do
// not parse or carry no known body. `what` names the bytes in the message ("frame", ...).
void parse_frame(const char* data, size_t size, Frame& frame, const char* what);

}  // namespace urs::planet::detail
