#pragma once
// Random identifiers (the server instance). Not secrets: uniqueness is all that matters, so
// std::random_device seeding a fresh engine is enough. Secrets come from util::random_secret_hex.

#include <cstddef>
#include <random>
#include <string>

namespace urs::planet::detail {

// 2 * bytes lowercase hex digits.
inline std::string random_hex(size_t bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::random_device device;
  std::mt19937_64 engine((uint64_t{device()} << 32) ^ device());
  std::string out;
  out.reserve(2 * bytes);
  for (size_t i = 0; i < bytes; ++i) {
    const auto byte = static_cast<unsigned>(engine() & 0xff);
    out.push_back(kDigits[byte >> 4]);
    out.push_back(kDigits[byte & 0xf]);
  }
  return out;
}

}  // namespace urs::planet::detail
