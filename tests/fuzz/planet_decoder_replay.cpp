// Runs LLVMFuzzerTestOneInput over every file of a corpus directory (a regression test without
// libFuzzer), or writes the seed corpus.
//
//   planet_decoder_fuzz_replay DIR                 replay; fails if DIR holds no file
//   planet_decoder_fuzz_replay --write-seeds DIR   (re)generate the seeds

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "urs/planet/codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {

using urs::planet::Frame;

std::string prefix(uint32_t size) {
  std::string out;
  urs::planet::append_length_prefix(out, size);
  return out;
}

std::string drain(urs::planet::Outbox& outbox) {
  std::string out;
  while (auto wire = outbox.pop()) out += *wire;
  return out;
}

// Byte 0 selects the slice size (see planet_decoder_fuzz.cpp): 0 = whole, 1 = byte by byte.
std::vector<std::pair<std::string, std::string>> seeds() {
  using urs::planet::encode_frame;
  std::vector<std::pair<std::string, std::string>> out;

  Frame hello;
  hello.mutable_hello()->set_version(1);
  hello.mutable_hello()->set_token("t");
  hello.mutable_hello()->set_peer_name("sam@robot1");
  hello.mutable_hello()->set_role(urs::planet::SAM);
  hello.mutable_hello()->set_session_secret("abc");
  out.emplace_back("hello_whole", std::string(1, '\0') + encode_frame(hello));
  out.emplace_back("hello_bytewise", std::string(1, '\1') + encode_frame(hello));

  Frame request;
  request.mutable_request()->set_call_id(7);
  request.mutable_request()->set_service("robot1.navigation");
  request.mutable_request()->set_operation("moveTo");
  request.mutable_request()->set_payload("\x09\x00\x00\x00\x00\x00\x00\xf0\x3f");
  request.mutable_request()->set_deadline_ms(1000);
  Frame event;
  event.mutable_event()->set_subscription_id(1);
  event.mutable_event()->set_seq(42);
  event.mutable_event()->set_topic("kr/robot1/arrived");
  event.mutable_event()->set_source("sam@robot1");
  Frame ping;
  ping.mutable_ping()->set_nonce(9);
  out.emplace_back("mixed_stream_sliced7",
                   std::string(1, '\7') + encode_frame(request) + encode_frame(event) + encode_frame(ping));

  // A 2,000-byte request chunked at 512 bytes, interleaved with another one and a small frame.
  urs::planet::Outbox outbox(urs::planet::kMinChunkBytes);
  Frame big = request;
  big.mutable_request()->set_payload(std::string(2000, 'i'));
  Frame big2 = big;
  big2.mutable_request()->set_call_id(8);
  outbox.push(big);
  outbox.push(big2);
  outbox.push(ping);
  out.emplace_back("chunked_interleaved", std::string(1, '\0') + drain(outbox));

  // The handshake state machine: a Hello, then chunked messages within the session's limits.
  urs::planet::Outbox session(urs::planet::kMinChunkBytes);
  session.push(big);
  session.push(big2);
  out.emplace_back("hello_then_chunked", std::string(1, '\0') + encode_frame(hello) + drain(session));

  Frame chunk;
  chunk.mutable_chunk()->set_message_id(1);
  chunk.mutable_chunk()->set_total_bytes(10);
  chunk.mutable_chunk()->set_offset(4);
  chunk.mutable_chunk()->set_data("abc");
  out.emplace_back("chunk_unknown_id", std::string(1, '\0') + encode_frame(chunk));

  out.emplace_back("oversized_length", std::string(1, '\0') + prefix(0x7fffffff) + "xx");
  out.emplace_back("zero_length", std::string(1, '\3') + prefix(0));
  out.emplace_back("garbage_body", std::string(1, '\0') + prefix(4) + "\xff\xff\xff\xff");
  return out;
}

int write_seeds(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  for (const auto& [name, bytes] : seeds()) {
    std::ofstream(dir / name, std::ios::binary) << bytes;
  }
  std::printf("wrote %zu seeds to %s\n", seeds().size(), dir.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::string(argv[1]) == "--write-seeds") return write_seeds(argv[2]);
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR | --write-seeds DIR\n", argv[0]);
    return 2;
  }
  size_t replayed = 0;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(argv[1], error)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
    ++replayed;
  }
  if (error || replayed == 0) {
    std::fprintf(stderr, "no corpus files in %s%s%s\n", argv[1], error ? ": " : "",
                 error ? error.message().c_str() : "");
    return 1;
  }
  std::printf("replayed %zu inputs from %s\n", replayed, argv[1]);
  return 0;
}
