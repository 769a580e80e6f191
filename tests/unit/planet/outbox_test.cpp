// Outbox scheduling: priority frames first, small frames never wait behind more than one chunk,
// round-robin between large messages, order kept for Events and Publishes.

#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <set>

#include "urs/planet/codec.hpp"

namespace urs::planet {
namespace {

using google::protobuf::util::MessageDifferencer;

constexpr uint32_t kChunk = 64u << 10;
constexpr size_t kImage = 921600;  // a 640x480 RGB image

Frame request(uint64_t call_id, size_t payload_bytes) {
  Frame frame;
  frame.mutable_request()->set_call_id(call_id);
  frame.mutable_request()->set_service("svc");
  frame.mutable_request()->set_operation("op");
  frame.mutable_request()->set_payload(std::string(payload_bytes, static_cast<char>('a' + call_id)));
  return frame;
}

Frame event(uint64_t seq, size_t payload_bytes) {
  Frame frame;
  frame.mutable_event()->set_seq(seq);
  frame.mutable_event()->set_topic("t");
  frame.mutable_event()->set_payload(std::string(payload_bytes, 'e'));
  return frame;
}

Frame pong() {
  Frame frame;
  frame.mutable_pong()->set_nonce(5);
  return frame;
}

// One popped wire frame, decoded.
Frame decode_one(const std::string& wire) {
  FrameDecoder decoder(kChunk);
  Frame out;
  int count = 0;
  decoder.feed(wire, [&](Frame&& frame) {
    out = std::move(frame);
    ++count;
  });
  EXPECT_EQ(count, 1);
  return out;
}

TEST(PlanetOutbox, SmallCallQueuedBehindAnImageGoesOutFirst) {
  Outbox outbox(kChunk);
  outbox.push(request(1, kImage));
  outbox.push(request(2, 10));
  const Frame first = decode_one(*outbox.pop());
  ASSERT_TRUE(first.has_request());
  EXPECT_EQ(first.request().call_id(), 2u);
}

TEST(PlanetOutbox, SmallCallQueuedWhileAnImageIsSendingWaitsAtMostOneChunk) {
  for (int chunks_before : {1, 2, 5, 13}) {
    SCOPED_TRACE(chunks_before);
    Outbox outbox(kChunk);
    outbox.push(request(1, kImage));
    for (int i = 0; i < chunks_before; ++i) EXPECT_TRUE(decode_one(*outbox.pop()).has_chunk());
    outbox.push(request(2, 10));
    int chunks_between = 0;
    for (;;) {
      auto wire = outbox.pop();
      ASSERT_TRUE(wire);
      const Frame frame = decode_one(*wire);
      if (frame.has_request()) {
        EXPECT_EQ(frame.request().call_id(), 2u);
        break;
      }
      ++chunks_between;
    }
    EXPECT_LE(chunks_between, 1);
  }
}

TEST(PlanetOutbox, EverySmallFrameGetsATurnBetweenChunks) {
  Outbox outbox(kChunk);
  outbox.push(request(1, kImage));
  for (uint64_t id = 2; id < 6; ++id) outbox.push(request(id, 10));
  std::string pattern;
  while (auto wire = outbox.pop()) pattern += decode_one(*wire).has_chunk() ? 'C' : 's';
  EXPECT_EQ(pattern.substr(0, 9), "sCsCsCsCC");
}

TEST(PlanetOutbox, PriorityFramesJumpTheQueue) {
  Outbox outbox(kChunk);
  outbox.push(request(1, kImage));
  outbox.push(request(2, 10));
  EXPECT_TRUE(decode_one(*outbox.pop()).has_request());
  EXPECT_TRUE(decode_one(*outbox.pop()).has_chunk());
  outbox.push(pong());
  EXPECT_TRUE(decode_one(*outbox.pop()).has_pong());
}

TEST(PlanetOutbox, LargeMessagesTakeTurnsAndReassemble) {
  Outbox outbox(kChunk);
  const Frame a = request(1, kImage);
  const Frame b = request(2, kImage / 2);
  outbox.push(a);
  outbox.push(b);
  std::vector<uint64_t> ids;
  std::string stream;
  while (auto wire = outbox.pop()) {
    ids.push_back(decode_one(*wire).chunk().message_id());
    stream += *wire;
  }
  ASSERT_GE(ids.size(), 4u);
  EXPECT_NE(ids[0], ids[1]);  // alternating while both are in progress
  EXPECT_EQ(ids[0], ids[2]);
  EXPECT_NE(ids[2], ids[3]);

  CodecLimits limits;
  limits.max_frame_bytes = kChunk;
  MessageDecoder decoder(limits);
  std::vector<Frame> out;
  decoder.feed(stream, [&](Frame&& frame) { out.push_back(std::move(frame)); });
  ASSERT_EQ(out.size(), 2u);
  EXPECT_TRUE(MessageDifferencer::Equals(out[0], b));  // the smaller one completes first
  EXPECT_TRUE(MessageDifferencer::Equals(out[1], a));
  EXPECT_TRUE(outbox.empty());
  EXPECT_EQ(outbox.queued_bytes(), 0u);
}

TEST(PlanetOutbox, EventsKeepTheirOrderWhateverTheirSize) {
  Outbox outbox(kChunk);
  outbox.push(event(1, kImage));
  outbox.push(event(2, 10));
  outbox.push(event(3, 200000));
  outbox.push(event(4, 10));
  CodecLimits limits;
  limits.max_frame_bytes = kChunk;
  MessageDecoder decoder(limits);
  std::vector<uint64_t> seqs;
  while (auto wire = outbox.pop()) {
    decoder.feed(*wire, [&](Frame&& frame) { seqs.push_back(frame.event().seq()); });
  }
  EXPECT_EQ(seqs, (std::vector<uint64_t>{1, 2, 3, 4}));
}

TEST(PlanetOutbox, BoundsTheMessagesInProgressForTheReceiver) {
  Outbox outbox(kChunk, /*max_active_chunked=*/2);
  for (uint64_t id = 1; id <= 6; ++id) outbox.push(request(id, 3 * kChunk));
  CodecLimits limits;
  limits.max_frame_bytes = kChunk;
  limits.max_partial_messages = 2;  // would throw if a third message were started
  MessageDecoder decoder(limits);
  int complete = 0;
  while (auto wire = outbox.pop()) decoder.feed(*wire, [&](Frame&&) { ++complete; });
  EXPECT_EQ(complete, 6);
}

TEST(PlanetOutbox, CountsQueuedBytesAndClears) {
  Outbox outbox(kChunk);
  const size_t a = outbox.push(request(1, kImage));
  const size_t b = outbox.push(request(2, 10));
  EXPECT_EQ(outbox.queued_bytes(), a + b);
  EXPECT_EQ(outbox.queued_frames(), 2u);
  outbox.pop();
  EXPECT_EQ(outbox.queued_bytes(), a);
  outbox.clear();
  EXPECT_TRUE(outbox.empty());
  EXPECT_EQ(outbox.queued_bytes(), 0u);
  EXPECT_FALSE(outbox.pop());
}

TEST(PlanetOutbox, EveryWireFrameFitsTheChunkSize) {
  for (uint32_t chunk : {kMinChunkBytes, 1000u, kChunk}) {
    SCOPED_TRACE(chunk);
    Outbox outbox(chunk);
    outbox.push(request(1, 50000));
    outbox.push(event(2, 50000));
    while (auto wire = outbox.pop()) EXPECT_LE(wire->size(), kLengthPrefixBytes + chunk);
  }
}

Frame reply(uint64_t call_id, size_t payload_bytes, size_t message_bytes) {
  Frame frame;
  frame.mutable_reply()->set_call_id(call_id);
  frame.mutable_reply()->set_status(Status::USER_EXCEPTION);
  frame.mutable_reply()->set_message(std::string(message_bytes, 'm'));
  std::string payload(payload_bytes, '\0');
  for (size_t i = 0; i < payload.size(); ++i) payload[i] = static_cast<char>(i % 251);
  frame.mutable_reply()->set_payload(std::move(payload));
  frame.mutable_reply()->set_exception_type("urs.Failure");
  return frame;
}

// The Outbox sends the pieces of a large message straight from its fields (WireFrame): the bytes
// on the wire must be exactly those of FrameEncoder, which serializes each Chunk frame.
TEST(PlanetOutbox, ChunksAreByteForByteThoseOfTheEncoder) {
  const std::vector<Frame> frames = {request(1, kImage), reply(7, kImage, 3000), reply(8, 70000, 0),
                                     event(9, 200000),   reply(10, 1, 100000),   request(11, 3 * kChunk - 100)};
  for (uint32_t chunk : {kMinChunkBytes, 1000u, 4096u, kChunk}) {
    for (const Frame& original : frames) {
      for (bool moved : {false, true}) {
        SCOPED_TRACE(std::to_string(chunk) + " bytes, " + std::string(frame_body_name(original)) +
                     (moved ? ", moved" : ", copied"));
        const std::vector<std::string> expected = FrameEncoder(chunk).encode(original, 1);
        Outbox outbox(chunk);
        Frame frame = original;
        if (moved) {
          outbox.push(std::move(frame));
        } else {
          outbox.push(frame);
        }
        std::vector<std::string> got;
        while (auto wire = outbox.pop_wire()) got.push_back(wire->flatten());
        ASSERT_EQ(got.size(), expected.size());
        for (size_t i = 0; i < got.size(); ++i) ASSERT_EQ(got[i], expected[i]) << "piece " << i;
        EXPECT_EQ(outbox.queued_bytes(), 0u);
        EXPECT_TRUE(outbox.empty());
      }
    }
  }
}

TEST(PlanetOutbox, AMovedLargeFrameIsSentFromItsOwnPayload) {
  Frame frame = reply(3, kImage, 0);
  const char* payload = frame.reply().payload().data();
  Outbox outbox(kChunk);
  outbox.push(std::move(frame));
  size_t referenced = 0;
  while (auto wire = outbox.pop_wire()) {
    for (std::string_view range : wire->body) {
      if (range.data() >= payload && range.data() + range.size() <= payload + kImage) {
        referenced += range.size();
      }
    }
    EXPECT_LE(wire->head.size(), 40u) << "only the Chunk header is copied";
    EXPECT_LE(wire->size(), kLengthPrefixBytes + kChunk);
  }
  EXPECT_EQ(referenced, kImage) << "every payload byte goes out from the pushed frame, uncopied";
}

TEST(PlanetOutbox, WireFramesKeepTheirMessageAliveAfterTheOutboxIsCleared) {
  Outbox outbox(kChunk);
  outbox.push(reply(3, kImage, 0));
  std::optional<WireFrame> first = outbox.pop_wire();
  std::optional<WireFrame> second = outbox.pop_wire();
  ASSERT_TRUE(first && second);
  outbox.clear();
  FrameDecoder decoder(kChunk);
  int chunks = 0;
  decoder.feed(first->flatten() + second->flatten(), [&](Frame&& frame) {
    EXPECT_TRUE(frame.has_chunk());
    ++chunks;
  });
  EXPECT_EQ(chunks, 2);
}

TEST(PlanetOutbox, PopAndPopWireGiveTheSameBytes) {
  Outbox a(kChunk);
  Outbox b(kChunk);
  for (Outbox* outbox : {&a, &b}) {
    outbox->push(request(1, kImage));
    outbox->push(pong());
    outbox->push(request(2, 10));
    outbox->push(event(3, 100000));
  }
  for (;;) {
    std::optional<std::string> flat = a.pop();
    std::optional<WireFrame> wire = b.pop_wire();
    ASSERT_EQ(flat.has_value(), wire.has_value());
    if (!flat) break;
    EXPECT_EQ(*flat, wire->flatten());
  }
}

}  // namespace
}  // namespace urs::planet
