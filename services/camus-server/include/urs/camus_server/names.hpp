#pragma once
// Names the server uses for itself.

namespace urs::camus_server {

// Owner of the built-in services and source of the events the server publishes itself.
inline constexpr const char* kServerPeerName = "camus-server";

}  // namespace urs::camus_server
