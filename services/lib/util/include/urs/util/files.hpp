#pragma once
// Files a long-running server re-reads while it serves (credentials, tokens, certificates on
// SIGHUP): read so that what the path names can never block or exhaust the reader.

#include <cstddef>
#include <string>

namespace urs::util {

// Reads `path` whole. It must be a regular file of at most `max_bytes`: the file is opened with
// O_NONBLOCK (so a FIFO nobody writes to does not block the open) and checked with fstat before
// anything is read, so a directory, FIFO, socket or device is refused, never read. Throws
// ConfigError naming the file and why ("'x' is a directory, not a regular file", "... is 20971520
// bytes; the limit is 1048576").
std::string read_regular_file(const std::string& path, size_t max_bytes);

// The largest credentials, token, certificate or key file a server re-reads.
inline constexpr size_t kMaxReloadFileBytes = 1u << 20;

}  // namespace urs::util
