#pragma once
// Command line of urs-camus-server, validated once into an immutable struct.

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>

#include "urs/camus_server/credentials_file.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/tls.hpp"

namespace urs::camus_server {

// What one session, one credential and all together may hold of the server (docs/planet.md §2;
// the server-wide limits in fair shares: planet::FairShare).
struct SemanticLimits {
  uint64_t max_topic_bytes = 512;  // topics and subscription patterns
  uint64_t max_topic_levels = 32;
  uint64_t max_subscriptions_per_session = 1000;
  uint64_t max_subscriptions_per_credential = 2500;
  uint64_t max_subscriptions = 20000;
  uint64_t max_pending_calls_per_session = 1000;
  uint64_t max_pending_calls_per_credential = 2500;
  uint64_t max_pending_calls = 10000;
  uint64_t max_deadline_ms = 86'400'000;
  uint64_t event_queue = 10000;                // publishes and subscribes waiting for the bus
  uint64_t event_queue_per_credential = 2500;  // of those, from one credential
  uint64_t event_queue_per_session = 1000;     // of those, from one session
  uint64_t event_queue_bytes = 64ull << 20;
  uint64_t event_queue_bytes_per_credential = 32ull << 20;
  // Transport (planet::ServerOptions): before the handshake, memory, connections, sessions.
  uint64_t max_hello_bytes = 4096;               // the one frame accepted before Welcome
  uint64_t max_message_bytes = 64ull << 20;      // largest reassembled message (announced in Welcome)
  uint64_t max_reassembly_bytes = 128ull << 20;  // per session: chunked messages in progress
  uint64_t max_send_queue_bytes = 256ull << 20;  // per session: frames waiting for a slow reader
  uint64_t max_buffered_bytes = 1ull << 30;      // all sessions: reassembly buffers + send queues
  uint64_t max_buffered_bytes_per_credential = 512ull << 20;
  uint64_t max_connections = 10000;  // lowered at start to what the descriptors allow
  uint64_t max_connections_per_address = 1000;
  uint64_t max_sessions_per_credential = 1000;
  uint64_t max_resumable_sessions = 10000;  // closed sessions kept resumable
  uint64_t max_resumable_sessions_per_credential = 1000;
  // Percent of every server-wide limit kept for sam and operator sessions and the server itself.
  uint64_t reserved_percent = 20;
};

struct ServerConfig {
  std::string space;
  util::Endpoint listen;
  CredentialSources credentials;  // none given = an open server (everyone is "anonymous", operator)
  std::string data_dir;           // empty = everything in memory (nothing survives a restart)
  std::string tasks_dir;          // empty = none
  std::string port_file;          // empty = none
  uint32_t heartbeat_ms = 1000;
  uint32_t heartbeat_timeout_ms = 3000;
  uint32_t default_deadline_ms = 10000;
  uint64_t event_retention = 100000;
  SemanticLimits limits;
  util::TlsConfig tls;                  // --tls-cert/--tls-key/--tls-client-ca
  bool allow_plaintext_tokens = false;  // tokens over plain TCP from non-loopback peers
  std::string log_level = "info";
  std::string log_format = "text";  // --log-format: text or json lines
  std::string metrics_listen;       // --metrics-listen HOST:PORT; empty: no metrics endpoint
};

// Parses and validates the command line. Throws util::ConfigError with one line naming the flag
// and the bad value. Returns nullopt when --help was asked for (help already written to `out`).
std::optional<ServerConfig> parse_command_line(int argc, const char* const* argv, std::ostream& out);

}  // namespace urs::camus_server
