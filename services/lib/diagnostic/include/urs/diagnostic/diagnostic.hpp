#pragma once
// The logic of the URS::Diagnostic service (idl/urs/Diagnostic.idl), shared by its hostings: the
// service agent in urs-sam and the RT-Component in urs-rtc-manager answer alike.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace urs::diagnostic {

inline constexpr std::uint32_t kMaxBlobBytes = 64u << 20;
inline constexpr std::uint32_t kMaxSleepMs = 10u * 60u * 1000u;

// `size` bytes with byte i = i % 251.
std::string patterned_bytes(std::uint32_t size);
// FNV-1a 64 of the bytes.
std::uint64_t fnv1a64(const void* data, std::size_t size);

// The reason a request is refused, or nullopt if it is within the limits.
std::optional<std::string> check_sleep(std::uint32_t ms);
std::optional<std::string> check_blob(std::uint32_t size);

}  // namespace urs::diagnostic
