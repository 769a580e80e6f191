#pragma once
// Secrets: tokens hashed for storage, compared in constant time, and random secrets from the
// operating system's generator (OpenSSL RAND_bytes). Thread-safe.

#include <cstddef>
#include <string>
#include <string_view>

namespace urs::util {

// SHA-256 of `data`: 64 lowercase hex digits.
std::string sha256_hex(std::string_view data);

// True if a == b; the time taken depends on the sizes only, not on the contents.
bool constant_time_equal(std::string_view a, std::string_view b);

// 2 * bytes lowercase hex digits from a cryptographically secure generator. Throws
// std::runtime_error if the generator fails (never returns a weak secret).
std::string random_secret_hex(size_t bytes);

// True if `text` is exactly 64 hex digits (either case), the form sha256_hex() writes.
bool is_sha256_hex(std::string_view text);

}  // namespace urs::util
