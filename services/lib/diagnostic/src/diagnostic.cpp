#include "urs/diagnostic/diagnostic.hpp"

#include <algorithm>
#include <cstring>

namespace urs::diagnostic {

// One period, then copies of what is already filled, doubling (a per-byte loop costs ~1 ms for
// a 921,600-byte image, which would dominate the call).
std::string patterned_bytes(std::uint32_t size) {
  std::string data(size, '\0');
  const std::uint32_t period = std::min<std::uint32_t>(size, 251);
  for (std::uint32_t i = 0; i < period; ++i) data[i] = static_cast<char>(i);
  for (std::uint32_t filled = period; filled < size;) {
    const std::uint32_t n = std::min(filled, size - filled);  // filled is a multiple of 251
    std::memcpy(&data[filled], data.data(), n);
    filled += n;
  }
  return data;
}

std::uint64_t fnv1a64(const void* data, std::size_t size) {
  std::uint64_t hash = 14695981039346656037ull;
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= 1099511628211ull;
  }
  return hash;
}

std::optional<std::string> check_sleep(std::uint32_t ms) {
  if (ms <= kMaxSleepMs) return std::nullopt;
  return "sleep: ms=" + std::to_string(ms) + " is over the limit of " + std::to_string(kMaxSleepMs);
}

std::optional<std::string> check_blob(std::uint32_t size) {
  if (size <= kMaxBlobBytes) return std::nullopt;
  return "blob: size=" + std::to_string(size) + " is over the limit of " + std::to_string(kMaxBlobBytes) + " bytes";
}

}  // namespace urs::diagnostic
