#pragma once
// urs link BRIDGE: the link to each other space as one bridge of this space meets it, read from
// that bridge's metrics endpoint (urs-bridge --metrics-listen; docs/operations.md, Monitoring):
// reachable or lost and since when, its participants and services, the round trips of this
// bridge's calls to it (count, last, mean) and the failures the link gave them, by status, with
// the time of the last one. What the endpoint sends is bounded (4 MiB, the timeout) and parsed as
// the Prometheus text format; only the urslink_bridge_link_* families are read.

#include <chrono>
#include <cstdint>
#include <string>

namespace urs::cli {

// "42s", "7m", "3h": how long ago `unix_seconds` was (0 if in the future).
std::string ago(int64_t unix_seconds);

// Prints the table (or, with `json`, one JSON object {"spaces": [...]}) for the bridge whose
// metrics endpoint is `address` (HOST:PORT); the exit code: 0, or 1 with the reason on stderr.
int run_link_command(const std::string& address, bool json, std::chrono::milliseconds timeout);

}  // namespace urs::cli
