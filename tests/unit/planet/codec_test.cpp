// FrameDecoder, Reassembler, MessageDecoder and FrameEncoder on plain byte strings.

#include "urs/planet/codec.hpp"

#include <gmock/gmock.h>
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <set>

#include "sample_frames.hpp"

namespace urs::planet {
namespace {

using google::protobuf::util::MessageDifferencer;
using ::testing::AllOf;
using ::testing::HasSubstr;

std::vector<Frame> decode_whole(FrameDecoder& decoder, const std::string& bytes) {
  std::vector<Frame> out;
  decoder.feed(bytes, [&](Frame&& frame) { out.push_back(std::move(frame)); });
  return out;
}

std::vector<Frame> decode_bytewise(FrameDecoder& decoder, const std::string& bytes) {
  std::vector<Frame> out;
  for (char byte : bytes) {
    decoder.feed(std::string_view(&byte, 1), [&](Frame&& frame) { out.push_back(std::move(frame)); });
  }
  return out;
}

template <typename Fn>
ProtocolError expect_protocol_error(Fn&& fn) {
  try {
    fn();
  } catch (const ProtocolError& error) {
    return error;
  }
  ADD_FAILURE() << "no ProtocolError thrown";
  return ProtocolError(ProtocolErrorCode::kMalformedFrame, "none");
}

std::string be32(uint32_t value) {
  std::string out;
  append_length_prefix(out, value);
  return out;
}

// ---- round trips --------------------------------------------------------------------------------

TEST(PlanetFrameDecoder, SampleCoversEveryFrameType) {
  std::set<int> cases;
  for (const Frame& frame : testing::sample_frames()) cases.insert(frame.body_case());
  EXPECT_EQ(cases.size(), static_cast<size_t>(Frame::descriptor()->oneof_decl(0)->field_count()));
}

// Every sample frame, encoded and fed to a fresh decoder by `decode`, comes out whole and equal,
// leaving nothing buffered.
void expect_round_trips(std::vector<Frame> (*decode)(FrameDecoder&, const std::string&)) {
  for (const Frame& frame : testing::sample_frames()) {
    SCOPED_TRACE(std::string(frame_body_name(frame)));
    FrameDecoder decoder(1 << 16);
    auto out = decode(decoder, encode_frame(frame));
    ASSERT_EQ(out.size(), 1u);
    EXPECT_TRUE(MessageDifferencer::Equals(out[0], frame));
    EXPECT_EQ(decoder.buffered_bytes(), 0u);
  }
}

TEST(PlanetFrameDecoder, RoundTripsEveryFrameTypeFedWhole) { expect_round_trips(decode_whole); }

TEST(PlanetFrameDecoder, RoundTripsEveryFrameTypeFedOneByteAtATime) { expect_round_trips(decode_bytewise); }

TEST(PlanetFrameDecoder, ManyFramesInOneSliceAndAcrossArbitrarySplits) {
  const auto frames = testing::sample_frames();
  std::string stream;
  for (const Frame& frame : frames) stream += encode_frame(frame);
  for (size_t split : {size_t{1}, size_t{3}, size_t{7}, size_t{64}, stream.size()}) {
    SCOPED_TRACE(split);
    FrameDecoder decoder(1 << 16);
    std::vector<Frame> out;
    for (size_t at = 0; at < stream.size(); at += split) {
      decoder.feed(std::string_view(stream).substr(at, split), [&](Frame&& frame) { out.push_back(std::move(frame)); });
    }
    ASSERT_EQ(out.size(), frames.size());
    for (size_t i = 0; i < frames.size(); ++i) {
      EXPECT_TRUE(MessageDifferencer::Equals(out[i], frames[i])) << i;
    }
    EXPECT_EQ(decoder.frames_decoded(), frames.size());
  }
}

// ---- bad input ----------------------------------------------------------------------------------

TEST(PlanetFrameDecoder, RejectsOversizedLengthBeforeReadingTheBody) {
  FrameDecoder decoder(65536);
  // Only the 4-byte prefix is fed: the error must come from the length alone, so nothing was
  // allocated for a 4 GiB body.
  auto error = expect_protocol_error([&] { decode_whole(decoder, be32(0xffffffffu)); });
  EXPECT_EQ(error.code(), ProtocolErrorCode::kFrameTooLarge);
  EXPECT_EQ(error.status(), Status::PAYLOAD_TOO_LARGE);
  EXPECT_THAT(error.what(), AllOf(HasSubstr("frame of 4294967295 bytes"), HasSubstr("limit of 65536 bytes"),
                                  HasSubstr("raise the receiver's chunk_bytes")));
  EXPECT_LE(decoder.buffered_bytes(), kLengthPrefixBytes);
}

TEST(PlanetFrameDecoder, AcceptsAFrameExactlyAtTheLimit) {
  Frame frame;
  frame.mutable_request()->set_payload(std::string(1000, 'x'));
  const size_t size = frame.ByteSizeLong();
  FrameDecoder exact(size);
  EXPECT_EQ(decode_whole(exact, encode_frame(frame)).size(), 1u);
  FrameDecoder below(size - 1);
  auto error = expect_protocol_error([&] { decode_whole(below, encode_frame(frame)); });
  EXPECT_EQ(error.code(), ProtocolErrorCode::kFrameTooLarge);
}

TEST(PlanetFrameDecoder, RejectsZeroLength) {
  FrameDecoder decoder(65536);
  auto error = expect_protocol_error([&] { decode_whole(decoder, be32(0)); });
  EXPECT_EQ(error.code(), ProtocolErrorCode::kEmptyFrame);
  EXPECT_EQ(error.status(), Status::BAD_ARGUMENTS);
  EXPECT_THAT(error.what(), HasSubstr("zero-length frame"));
}

TEST(PlanetFrameDecoder, RejectsGarbage) {
  FrameDecoder decoder(65536);
  const std::string garbage = be32(5) + std::string("\xff\xff\xff\xff\xff", 5);
  auto error = expect_protocol_error([&] { decode_bytewise(decoder, garbage); });
  EXPECT_EQ(error.code(), ProtocolErrorCode::kMalformedFrame);
  EXPECT_THAT(error.what(), HasSubstr("frame of 5 bytes does not parse as a urs.planet.Frame"));
}

TEST(PlanetFrameDecoder, RejectsAFrameWithoutAKnownBody) {
  FrameDecoder decoder(65536);
  // Field 99 (varint 1): valid protobuf, but no Frame body this version knows.
  const std::string unknown = std::string("\x98\x06\x01", 3);
  auto error = expect_protocol_error([&] { decode_whole(decoder, be32(3) + unknown); });
  EXPECT_EQ(error.code(), ProtocolErrorCode::kMalformedFrame);
  EXPECT_THAT(error.what(), HasSubstr("no known body"));
}

TEST(PlanetFrameDecoder, HttpRequestIsRejectedByItsLength) {
  FrameDecoder decoder(65536);
  auto error = expect_protocol_error([&] { decode_whole(decoder, "GET / HTTP/1.1\r\nHost: x\r\n\r\n"); });
  EXPECT_EQ(error.code(), ProtocolErrorCode::kFrameTooLarge);
}

// ---- chunking and reassembly --------------------------------------------------------------------

Frame big_request(size_t payload_bytes, uint64_t call_id = 1) {
  Frame frame;
  Request& request = *frame.mutable_request();
  request.set_call_id(call_id);
  request.set_service("robot1.camera");
  request.set_operation("upload");
  std::string payload(payload_bytes, '\0');
  for (size_t i = 0; i < payload.size(); ++i) payload[i] = static_cast<char>(i * 131 + 7);
  request.set_payload(std::move(payload));
  return frame;
}

TEST(PlanetFrameEncoder, SmallFrameIsOneWireFrame) {
  FrameEncoder encoder(64u << 10);
  Frame frame = testing::sample_frames()[3];
  auto wire = encoder.encode(frame, 1);
  ASSERT_EQ(wire.size(), 1u);
  EXPECT_EQ(wire[0], encode_frame(frame));
}

TEST(PlanetFrameEncoder, ChunksALargeFrameAndTheDecoderReassemblesIt) {
  const uint32_t chunk_bytes = 64u << 10;
  FrameEncoder encoder(chunk_bytes);
  const Frame frame = big_request(921600);
  const auto wire = encoder.encode(frame, 77);
  const size_t serialized = frame.ByteSizeLong();
  EXPECT_EQ(wire.size(), (serialized + encoder.piece_bytes() - 1) / encoder.piece_bytes());
  std::string stream;
  for (const auto& piece : wire) {
    EXPECT_LE(piece.size(), kLengthPrefixBytes + chunk_bytes);
    stream += piece;
  }
  CodecLimits limits;
  limits.max_frame_bytes = chunk_bytes;
  for (bool bytewise : {false, true}) {
    SCOPED_TRACE(bytewise ? "one byte at a time" : "whole");
    MessageDecoder decoder(limits);
    std::vector<Frame> out;
    auto sink = [&](Frame&& message) { out.push_back(std::move(message)); };
    if (bytewise) {
      for (char byte : stream) decoder.feed(std::string_view(&byte, 1), sink);
    } else {
      decoder.feed(stream, sink);
    }
    ASSERT_EQ(out.size(), 1u);
    EXPECT_TRUE(MessageDifferencer::Equals(out[0], frame));
    EXPECT_EQ(decoder.frames_decoded(), wire.size());
    EXPECT_EQ(decoder.partial_messages(), 0u);
  }
}

TEST(PlanetFrameEncoder, RejectsATinyChunkSize) { EXPECT_THROW(FrameEncoder(100), std::invalid_argument); }

Chunk piece(uint64_t id, uint64_t total, uint64_t offset, std::string data, bool last) {
  Chunk chunk;
  chunk.set_message_id(id);
  chunk.set_total_bytes(total);
  chunk.set_offset(offset);
  chunk.set_data(std::move(data));
  chunk.set_last(last);
  return chunk;
}

CodecLimits small_limits() {
  CodecLimits limits;
  limits.max_frame_bytes = 4096;
  limits.max_message_bytes = 1000;
  limits.max_partial_messages = 2;
  return limits;
}

TEST(PlanetReassembler, ReassemblesInterleavedMessages) {
  Reassembler reassembler(small_limits());
  EXPECT_FALSE(reassembler.add(piece(1, 6, 0, "abc", false)));
  EXPECT_FALSE(reassembler.add(piece(2, 4, 0, "wx", false)));
  EXPECT_EQ(reassembler.partial_messages(), 2u);
  EXPECT_EQ(reassembler.buffered_bytes(), 5u);
  auto second = reassembler.add(piece(2, 4, 2, "yz", true));
  ASSERT_TRUE(second);
  EXPECT_EQ(*second, "wxyz");
  auto first = reassembler.add(piece(1, 6, 3, "def", true));
  ASSERT_TRUE(first);
  EXPECT_EQ(*first, "abcdef");
  EXPECT_EQ(reassembler.partial_messages(), 0u);
  EXPECT_EQ(reassembler.buffered_bytes(), 0u);
  // An id may be reused once its message is complete.
  EXPECT_EQ(*reassembler.add(piece(1, 2, 0, "ok", true)), "ok");
}

TEST(PlanetReassembler, ReusesARecycledBufferForTheNextMessage) {
  Reassembler reassembler(small_limits());
  EXPECT_FALSE(reassembler.add(piece(1, 6, 0, "abc", false)));
  std::string first = *reassembler.add(piece(1, 6, 3, "def", true));
  EXPECT_EQ(first, "abcdef");
  first.reserve(900);  // a buffer the size of a large message
  const char* memory = first.data();
  reassembler.recycle(std::move(first));
  EXPECT_FALSE(reassembler.add(piece(2, 4, 0, "wx", false)));
  EXPECT_EQ(reassembler.buffered_bytes(), 2u);
  const std::string second = *reassembler.add(piece(2, 4, 2, "yz", true));
  EXPECT_EQ(second, "wxyz");
  EXPECT_EQ(second.data(), memory) << "the recycled buffer was not reused";
  // Buffers larger than kMaxRecycledBytes are released, not kept.
  std::string huge;
  huge.reserve(Reassembler::kMaxRecycledBytes + 1);
  reassembler.recycle(std::move(huge));
  EXPECT_FALSE(reassembler.add(piece(3, 4, 0, "ab", false)));
  EXPECT_LE(reassembler.add(piece(3, 4, 2, "cd", true))->capacity(), Reassembler::kMaxRecycledBytes);
}

TEST(PlanetReassembler, RejectsTotalOverTheLimitBeforeAllocating) {
  Reassembler reassembler(small_limits());
  auto error = expect_protocol_error([&] { reassembler.add(piece(5, 1ull << 40, 0, "x", false)); });
  EXPECT_EQ(error.code(), ProtocolErrorCode::kMessageTooLarge);
  EXPECT_EQ(error.status(), Status::PAYLOAD_TOO_LARGE);
  EXPECT_THAT(error.what(), AllOf(HasSubstr("1099511627776 bytes"), HasSubstr("limit of 1000"),
                                  HasSubstr("raise the receiver's max_message_bytes")));
  EXPECT_EQ(reassembler.buffered_bytes(), 0u);
}

TEST(PlanetReassembler, BoundsTheNumberOfPartialMessages) {
  Reassembler reassembler(small_limits());
  reassembler.add(piece(1, 10, 0, "a", false));
  reassembler.add(piece(2, 10, 0, "a", false));
  auto error = expect_protocol_error([&] { reassembler.add(piece(3, 10, 0, "a", false)); });
  EXPECT_EQ(error.code(), ProtocolErrorCode::kTooManyPartialMessages);
  EXPECT_THAT(error.what(), HasSubstr("limit of 2 (max_partial_messages)"));
}

TEST(PlanetReassembler, DetectsInconsistentPieces) {
  struct Case {
    const char* name;
    std::vector<Chunk> pieces;
    ProtocolErrorCode code;
    const char* text;
  };
  const std::vector<Case> cases = {
      {"total changes",
       {piece(1, 10, 0, "abc", false), piece(1, 11, 3, "d", false)},
       ProtocolErrorCode::kInconsistentChunk,
       "total_bytes changed from 10 to 11"},
      {"gap",
       {piece(1, 10, 0, "abc", false), piece(1, 10, 4, "d", false)},
       ProtocolErrorCode::kInconsistentChunk,
       "piece at offset 4, expected offset 3"},
      {"overflow",
       {piece(1, 4, 0, "abc", false), piece(1, 4, 3, "de", true)},
       ProtocolErrorCode::kChunkOverflow,
       "more than total_bytes 4"},
      {"first piece overflows",
       {piece(1, 2, 0, "abc", true)},
       ProtocolErrorCode::kChunkOverflow,
       "exceeds total_bytes 2"},
      {"unknown id", {piece(9, 10, 5, "abc", false)}, ProtocolErrorCode::kUnknownChunk, "never started"},
      {"last too early",
       {piece(1, 10, 0, "abc", true)},
       ProtocolErrorCode::kInconsistentChunk,
       "last piece ends at 3 of 10"},
      {"complete but not last",
       {piece(1, 3, 0, "abc", false)},
       ProtocolErrorCode::kInconsistentChunk,
       "not marked last"},
      {"empty piece", {piece(1, 3, 0, "", false)}, ProtocolErrorCode::kInconsistentChunk, "carries no data"},
      {"zero total", {piece(1, 0, 0, "a", true)}, ProtocolErrorCode::kInconsistentChunk, "total_bytes 0"},
  };
  for (const Case& test : cases) {
    SCOPED_TRACE(test.name);
    Reassembler reassembler(small_limits());
    auto error = expect_protocol_error([&] {
      for (Chunk chunk : test.pieces) reassembler.add(std::move(chunk));
    });
    EXPECT_EQ(error.code(), test.code) << protocol_error_name(error.code());
    EXPECT_THAT(error.what(), HasSubstr(test.text));
  }
}

TEST(PlanetMessageDecoder, RejectsANestedChunk) {
  Frame inner;
  *inner.mutable_chunk() = piece(1, 1, 0, "x", true);
  const std::string inner_bytes = inner.SerializeAsString();
  Frame outer;
  *outer.mutable_chunk() = piece(2, inner_bytes.size(), 0, inner_bytes, true);
  MessageDecoder decoder(small_limits());
  auto error = expect_protocol_error([&] { decoder.feed(encode_frame(outer), [](Frame&&) {}); });
  EXPECT_EQ(error.code(), ProtocolErrorCode::kNestedChunk);
}

TEST(PlanetMessageDecoder, RejectsAReassembledMessageThatDoesNotParse) {
  Frame outer;
  *outer.mutable_chunk() = piece(2, 3, 0, "\xff\xff\xff", true);
  MessageDecoder decoder(small_limits());
  auto error = expect_protocol_error([&] { decoder.feed(encode_frame(outer), [](Frame&&) {}); });
  EXPECT_EQ(error.code(), ProtocolErrorCode::kMalformedFrame);
  EXPECT_THAT(error.what(), HasSubstr("reassembled message 2 of 3 bytes"));
}

TEST(PlanetMessageDecoder, BeforeTheHandshakeOnlyOneSmallUnchunkedFrame) {
  CodecLimits hello_limits;
  hello_limits.max_frame_bytes = 4096;
  hello_limits.before_handshake = true;
  Frame hello;
  hello.mutable_hello()->set_version(1);
  hello.mutable_hello()->set_peer_name("p");
  {
    MessageDecoder decoder(hello_limits);
    int frames = 0;
    decoder.feed(encode_frame(hello), [&](Frame&&) { ++frames; });
    EXPECT_EQ(frames, 1);
  }
  {
    // A chunk-wrapped Hello: refused, not reassembled.
    const std::string bytes = hello.SerializeAsString();
    Frame wrapped;
    *wrapped.mutable_chunk() = piece(1, bytes.size(), 0, bytes, true);
    MessageDecoder decoder(hello_limits);
    auto error = expect_protocol_error([&] { decoder.feed(encode_frame(wrapped), [](Frame&&) {}); });
    EXPECT_EQ(error.code(), ProtocolErrorCode::kChunkBeforeHandshake);
    EXPECT_EQ(error.status(), Status::PAYLOAD_TOO_LARGE);
    EXPECT_THAT(error.what(), HasSubstr("4096 bytes (max_hello_bytes)"));
  }
  {
    // A 64 MiB length: refused at the prefix, before anything of that size is allocated.
    MessageDecoder decoder(hello_limits);
    auto error = expect_protocol_error([&] { decoder.feed(be32(64u << 20), [](Frame&&) {}); });
    EXPECT_EQ(error.code(), ProtocolErrorCode::kFrameTooLarge);
    EXPECT_THAT(error.what(), AllOf(HasSubstr("67108864 bytes before the handshake"),
                                    HasSubstr("limit of 4096 bytes (max_hello_bytes)")));
  }
  {
    // After the handshake the session limits apply: chunks are reassembled.
    MessageDecoder decoder(hello_limits);
    CodecLimits open = hello_limits;
    open.max_frame_bytes = 65536;
    open.before_handshake = false;
    decoder.set_limits(open);
    const std::string bytes = hello.SerializeAsString();
    Frame wrapped;
    *wrapped.mutable_chunk() = piece(1, bytes.size(), 0, bytes, true);
    int frames = 0;
    decoder.feed(encode_frame(wrapped), [&](Frame&& frame) { frames += frame.has_hello(); });
    EXPECT_EQ(frames, 1);
  }
}

TEST(PlanetReassembler, BoundsTheBytesHeldPerConnectionAndServerWide) {
  constexpr uint64_t kMiB = 1u << 20;
  CodecLimits limits;
  limits.max_message_bytes = 10 * kMiB;
  limits.max_reassembly_bytes = 4 * kMiB;
  const std::string head(100, 'a');  // a first piece: its buffer starts at the 1 MiB initial reserve
  {
    // Each message in progress holds 1 MiB (the initial reserve): the fifth is one too many.
    Reassembler reassembler(limits);
    for (uint64_t id = 1; id <= 4; ++id) reassembler.add(piece(id, 10 * kMiB, 0, head, false));
    EXPECT_EQ(reassembler.held_bytes(), 4 * kMiB);
    auto error = expect_protocol_error([&] { reassembler.add(piece(5, 10 * kMiB, 0, head, false)); });
    EXPECT_EQ(error.code(), ProtocolErrorCode::kReassemblyLimit);
    EXPECT_EQ(error.status(), Status::RESOURCE_EXHAUSTED);
    EXPECT_THAT(error.what(), HasSubstr("would hold 5242880 bytes, more than the limit of 4194304 bytes "
                                        "(max_reassembly_bytes)"));
    EXPECT_EQ(reassembler.partial_messages(), 4u);
    EXPECT_EQ(reassembler.held_bytes(), 4 * kMiB);
  }
  {
    // Two connections share a 2 MiB budget; what one holds is handed back when it goes.
    constexpr uint64_t kTotal = 3 * kMiB / 2;
    limits.budget = std::make_shared<MemoryBudget>(2 * kMiB);
    auto first = std::make_unique<Reassembler>(limits);
    Reassembler second(limits);
    first->add(piece(1, kTotal, 0, head, false));
    first->add(piece(2, kTotal, 0, head, false));
    EXPECT_EQ(limits.budget->used(), 2 * kMiB);
    auto error = expect_protocol_error([&] { second.add(piece(1, kTotal, 0, head, false)); });
    EXPECT_EQ(error.code(), ProtocolErrorCode::kServerBudget);
    EXPECT_EQ(error.status(), Status::RESOURCE_EXHAUSTED);
    EXPECT_THAT(error.what(), HasSubstr("(max_buffered_bytes)"));
    first.reset();
    EXPECT_EQ(limits.budget->used(), 0u);
    second.add(piece(1, kTotal, 0, head, false));
    EXPECT_EQ(limits.budget->used(), kMiB);
    // A completed message is no longer counted.
    EXPECT_TRUE(second.add(piece(1, kTotal, head.size(), std::string(kTotal - head.size(), 'b'), true)));
    EXPECT_EQ(limits.budget->used(), 0u);
  }
}

TEST(PlanetProtocolError, NamesEveryCode) {
  for (auto code :
       {ProtocolErrorCode::kFrameTooLarge, ProtocolErrorCode::kEmptyFrame, ProtocolErrorCode::kMalformedFrame,
        ProtocolErrorCode::kMessageTooLarge, ProtocolErrorCode::kTooManyPartialMessages,
        ProtocolErrorCode::kInconsistentChunk, ProtocolErrorCode::kUnknownChunk, ProtocolErrorCode::kChunkOverflow,
        ProtocolErrorCode::kNestedChunk, ProtocolErrorCode::kChunkBeforeHandshake, ProtocolErrorCode::kReassemblyLimit,
        ProtocolErrorCode::kServerBudget}) {
    EXPECT_NE(protocol_error_name(code), "UNKNOWN_PROTOCOL_ERROR");
  }
}

}  // namespace
}  // namespace urs::planet
