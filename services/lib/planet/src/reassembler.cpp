#include <algorithm>
#include <cstring>

#include "codec_detail.hpp"
#include "urs/planet/codec.hpp"

namespace urs::planet {

using detail::fail;
using detail::n;

namespace {

// Initial buffer for a chunked message: its size is declared by the peer, so reserve at most this
// much up front and let the buffer grow with the data that actually arrives.
constexpr uint64_t kInitialReassemblyReserve = 1u << 20;

}  // namespace

Reassembler::Reassembler(const CodecLimits& limits) : limits_(limits) {}

std::optional<std::string> Reassembler::add(Chunk&& chunk) {
  const uint64_t id = chunk.message_id();
  const uint64_t total = chunk.total_bytes();
  const uint64_t offset = chunk.offset();
  const std::string& data = chunk.data();
  const std::string what = "chunked message " + n(id);

  if (total == 0) {
    fail(ProtocolErrorCode::kInconsistentChunk, what + " declares total_bytes 0");
  }
  if (total > limits_.max_message_bytes) {
    fail(ProtocolErrorCode::kMessageTooLarge,
         what + " of " + n(total) + " bytes exceeds the limit of " + n(limits_.max_message_bytes) +
             " bytes (max_message_bytes); send less per message or raise the receiver's "
             "max_message_bytes (ServerOptions::max_message_bytes / "
             "ClientOptions::max_message_bytes)");
  }
  if (data.empty()) {
    fail(ProtocolErrorCode::kInconsistentChunk, what + ": the piece at offset " + n(offset) + " carries no data");
  }

  auto it = partial_.find(id);
  if (it == partial_.end()) {
    if (offset != 0) {
      fail(ProtocolErrorCode::kUnknownChunk,
           what + ": piece at offset " + n(offset) +
               " of a message that was never started (its first piece, at offset 0, is missing)");
    }
    if (data.size() > total) {
      fail(ProtocolErrorCode::kChunkOverflow,
           what + ": a piece of " + n(data.size()) + " bytes exceeds total_bytes " + n(total));
    }
    if (data.size() == total) {
      if (!chunk.last()) {
        fail(ProtocolErrorCode::kInconsistentChunk,
             what + " reached total_bytes " + n(total) + " in a piece not marked last");
      }
      return std::move(*chunk.mutable_data());
    }
    if (chunk.last()) {
      fail(ProtocolErrorCode::kInconsistentChunk,
           what + ": the last piece ends at " + n(data.size()) + " of " + n(total) + " bytes");
    }
    if (partial_.size() >= limits_.max_partial_messages) {
      fail(ProtocolErrorCode::kTooManyPartialMessages,
           what + " would be one more chunked message in progress than the limit of " +
               n(limits_.max_partial_messages) +
               " (max_partial_messages); a sender must finish messages before starting more");
    }
    Partial& partial = partial_[id];
    partial.total = total;
    partial.data.swap(spare_);  // reuse the recycled buffer, if any (already held: counted as is)
    partial.accounted = partial.data.capacity();
    held_bytes_ += partial.accounted;
    if (limits_.budget) limits_.budget->force(partial.accounted);
    try {
      grow(partial, data.size(), what);
    } catch (const ProtocolError&) {
      forget(partial);
      partial_.erase(id);
      throw;
    }
    partial.data.append(data);
    buffered_bytes_ += data.size();
    return std::nullopt;
  }

  Partial& partial = it->second;
  if (total != partial.total) {
    fail(ProtocolErrorCode::kInconsistentChunk,
         what + ": total_bytes changed from " + n(partial.total) + " to " + n(total));
  }
  if (offset != partial.data.size()) {
    fail(ProtocolErrorCode::kInconsistentChunk,
         what + ": piece at offset " + n(offset) + ", expected offset " + n(partial.data.size()));
  }
  if (data.size() > total - partial.data.size()) {
    fail(ProtocolErrorCode::kChunkOverflow, what + ": pieces add up to " + n(partial.data.size() + data.size()) +
                                                " bytes, more than total_bytes " + n(total));
  }
  const bool complete = partial.data.size() + data.size() == total;
  if (complete != chunk.last()) {
    fail(ProtocolErrorCode::kInconsistentChunk,
         complete ? what + " reached total_bytes " + n(total) + " in a piece not marked last"
                  : what + ": the last piece ends at " + n(partial.data.size() + data.size()) + " of " + n(total) +
                        " bytes");
  }
  grow(partial, data.size(), what);
  partial.data.append(data);
  buffered_bytes_ += data.size();
  if (!complete) return std::nullopt;
  std::string message = std::move(partial.data);
  buffered_bytes_ -= message.size();
  forget(partial);
  partial_.erase(it);
  return message;
}

Reassembler::~Reassembler() {
  for (const auto& [id, partial] : partial_) forget(partial);
}

void Reassembler::set_limits(const CodecLimits& limits) {
  if (limits.budget != limits_.budget && held_bytes_ > 0) {
    if (limits_.budget) limits_.budget->give(held_bytes_);
    if (limits.budget) limits.budget->force(held_bytes_);
  }
  limits_ = limits;
}

void Reassembler::grow(Partial& partial, size_t more, const std::string& what) {
  const uint64_t need = partial.data.size() + more;  // never above total (checked by the caller)
  const uint64_t capacity = partial.data.capacity();
  if (need <= capacity) return;
  // The size is declared by the peer: start at kInitialReassemblyReserve at most and grow with
  // the data that actually arrives (doubling, never beyond total).
  const uint64_t target = std::max(need, std::min(partial.total, std::max(2 * capacity, kInitialReassemblyReserve)));
  const uint64_t extra = target - capacity;
  if (held_bytes_ + extra > limits_.max_reassembly_bytes) {
    fail(ProtocolErrorCode::kReassemblyLimit,
         what + ": the chunked messages in progress on this connection would hold " + n(held_bytes_ + extra) +
             " bytes, more than the limit of " + n(limits_.max_reassembly_bytes) +
             " bytes (max_reassembly_bytes); finish messages before starting more, or raise the "
             "receiver's max_reassembly_bytes");
  }
  std::string why;
  if (limits_.budget && !limits_.budget->take(extra, why)) {
    fail(ProtocolErrorCode::kServerBudget, what + ": " + n(extra) + " more bytes refused: " + why);
  }
  partial.data.reserve(static_cast<size_t>(target));
  const uint64_t grown = partial.data.capacity() - partial.accounted;
  if (limits_.budget && grown > extra) limits_.budget->force(grown - extra);
  if (limits_.budget && grown < extra) limits_.budget->give(extra - grown);
  partial.accounted += grown;
  held_bytes_ += grown;
}

void Reassembler::forget(const Partial& partial) {
  held_bytes_ -= partial.accounted;
  if (limits_.budget) limits_.budget->give(partial.accounted);
}

void Reassembler::recycle(std::string&& buffer) {
  if (buffer.capacity() > kMaxRecycledBytes || buffer.capacity() <= spare_.capacity()) return;
  buffer.clear();
  spare_ = std::move(buffer);
}

}  // namespace urs::planet
