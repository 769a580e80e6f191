#include "urs/util/trace.hpp"

#include <unistd.h>

#include <algorithm>
#include <iostream>
#include <random>

namespace urs::util {
namespace {

thread_local const TraceContext* g_current = nullptr;

// Ids need to be unique, not secret: one generator per thread, seeded once from the system's.
std::mt19937_64& generator() {
  thread_local std::mt19937_64 engine = [] {
    std::random_device device;
    std::seed_seq seed{device(), device(), device(), device()};
    return std::mt19937_64(seed);
  }();
  return engine;
}

template <size_t N>
void fill_random(std::array<uint8_t, N>& bytes) {
  do {
    for (size_t i = 0; i < N; i += 8) {
      uint64_t word = generator()();
      for (size_t j = 0; j < 8 && i + j < N; ++j) bytes[i + j] = static_cast<uint8_t>(word >> (8 * j));
    }
  } while (std::all_of(bytes.begin(), bytes.end(), [](uint8_t b) { return b == 0; }));
}

constexpr char kHex[] = "0123456789abcdef";

template <size_t N>
void append_hex(std::string& out, const std::array<uint8_t, N>& bytes) {
  for (uint8_t b : bytes) {
    out += kHex[b >> 4];
    out += kHex[b & 15];
  }
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;  // upper case is not valid in a traceparent
}

// Reads 2 * N lowercase hex digits at `text`; false if any is not one.
template <size_t N>
bool read_hex(std::string_view text, std::array<uint8_t, N>& bytes) {
  for (size_t i = 0; i < N; ++i) {
    const int high = hex_value(text[2 * i]);
    const int low = hex_value(text[2 * i + 1]);
    if (high < 0 || low < 0) return false;
    bytes[i] = static_cast<uint8_t>(high << 4 | low);
  }
  return true;
}

template <size_t N>
bool all_zero(const std::array<uint8_t, N>& bytes) {
  return std::all_of(bytes.begin(), bytes.end(), [](uint8_t b) { return b == 0; });
}

}  // namespace

std::string TraceContext::traceparent() const {
  std::string out = "00-";
  out.reserve(55);
  append_hex(out, trace_id);
  out += '-';
  append_hex(out, parent_id);
  out += '-';
  out += kHex[flags >> 4];
  out += kHex[flags & 15];
  return out;
}

std::string TraceContext::trace_id_hex() const {
  std::string out;
  out.reserve(32);
  append_hex(out, trace_id);
  return out;
}

std::optional<TraceContext> TraceContext::parse(std::string_view text) {
  // version "-" trace-id "-" parent-id "-" flags: 2 + 1 + 32 + 1 + 16 + 1 + 2.
  constexpr size_t kLength = 55;
  if (text.size() < kLength || text.size() > kMaxTraceparentBytes) return std::nullopt;
  std::array<uint8_t, 1> version{};
  if (!read_hex(text.substr(0, 2), version) || version[0] == 0xff) return std::nullopt;
  if (version[0] == 0 && text.size() != kLength) return std::nullopt;
  if (text.size() > kLength && text[kLength] != '-') return std::nullopt;  // a later version's own fields follow
  if (text[2] != '-' || text[35] != '-' || text[52] != '-') return std::nullopt;
  TraceContext trace;
  std::array<uint8_t, 1> flags{};
  if (!read_hex(text.substr(3, 32), trace.trace_id) || !read_hex(text.substr(36, 16), trace.parent_id) ||
      !read_hex(text.substr(53, 2), flags)) {
    return std::nullopt;
  }
  if (all_zero(trace.trace_id) || all_zero(trace.parent_id)) return std::nullopt;
  trace.flags = flags[0];
  return trace;
}

TraceContext TraceContext::start() {
  TraceContext trace;
  fill_random(trace.trace_id);
  fill_random(trace.parent_id);
  trace.flags = 1;
  return trace;
}

TraceContext TraceContext::child() const {
  TraceContext next = *this;
  fill_random(next.parent_id);
  return next;
}

const TraceContext* current_trace() { return g_current; }

TraceContext outgoing_trace() { return g_current != nullptr ? g_current->child() : TraceContext::start(); }

TraceScope::TraceScope(const TraceContext& trace) : TraceScope(std::optional<TraceContext>(trace)) {}

TraceScope::TraceScope(const std::optional<TraceContext>& trace) : trace_(trace) {
  if (!trace_) return;
  previous_ = g_current;
  g_current = &*trace_;
  entered_ = true;
}

TraceScope::~TraceScope() {
  if (entered_) g_current = previous_;
}

void show_trace_id(const TraceContext& trace, bool always) {
  if (always || isatty(STDERR_FILENO) == 1) std::cerr << "trace " << trace.trace_id_hex() << "\n";
}

}  // namespace urs::util
