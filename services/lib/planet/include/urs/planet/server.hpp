#pragma once
// Planet server transport: accepts TCP connections, performs the versioned, authenticated
// handshake, answers heartbeats, reassembles chunked messages and hands every other frame to a
// SessionHandler. It knows nothing of services, events or routing (that is the CAMUS server's).
//
// Identity: the Authenticator decides who each Hello speaks for (Session::identity()); the peer's
// own Hello.peer_name is for display only. The server issues each new session a random secret in
// Welcome; a Hello presenting it with the same credential resumes that session (same
// Identity::session). The secret is never logged.
//
// Threading: all handler callbacks run on the server's I/O threads and must not block; hand slow
// work to another thread and answer later through Session::send, which is thread-safe.

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "planet.pb.h"
#include "urs/planet/authenticator.hpp"
#include "urs/util/tls.hpp"

namespace urs::planet {

struct ServerOptions {
  std::string host = "0.0.0.0";
  uint16_t port = 0;  // 0 = ephemeral; read back with Server::port()
  std::string space;  // announced in Welcome
  // Who may connect (e.g. planet::Credentials). Null: an open server, where every peer is
  // admitted as kAnonymousIdentity with role OPERATOR.
  std::shared_ptr<const Authenticator> authenticator;
  std::chrono::milliseconds session_resume_window{600000};  // a closed session stays resumable this long
  // Closed sessions kept resumable: all together, and of one credential. A credential over its
  // share loses its own oldest first; when all together are too many, the credential holding
  // the most loses its oldest (docs/planet.md §4.3).
  size_t max_resumable_sessions = 10000;
  size_t max_resumable_sessions_per_credential = 1000;
  std::chrono::milliseconds heartbeat_interval{1000};
  std::chrono::milliseconds heartbeat_timeout{3000};  // silent peer is closed after this
  std::chrono::milliseconds handshake_timeout{5000};  // Hello must arrive within this
  uint64_t max_message_bytes = 64ull << 20;           // largest reassembled message accepted
  uint32_t chunk_bytes = 64u << 10;                   // larger frames are sent as chunks
  size_t max_send_queue_bytes = 256ull << 20;         // per session; beyond it the session is closed
  // Before Welcome a connection may send one un-chunked frame of at most this size (its Hello);
  // a larger length or any Chunk is refused before anything of the declared size is allocated.
  uint32_t max_hello_bytes = 4096;
  uint64_t max_reassembly_bytes = 128ull << 20;  // per session: chunked messages in progress
  // Reassembly buffers and send queues of all sessions together, and of one credential's (at
  // most max_buffered_bytes: a larger value counts as it).
  uint64_t max_buffered_bytes = 1ull << 30;
  uint64_t max_buffered_bytes_per_credential = 512ull << 20;
  // Open connections, handshaking ones included. Lowered at start to what the process's
  // descriptor limit (RLIMIT_NOFILE) leaves, so that accept() never runs out of descriptors
  // (Server::max_connections() says what was applied).
  size_t max_connections = 10000;
  size_t max_connections_per_address = 1000;  // of those, from one source address
  size_t max_sessions_per_credential = 1000;  // open sessions of one credential
  // Percent of every server-wide budget (max_connections, max_buffered_bytes,
  // max_resumable_sessions) that sessions of role client cannot use: kept for sam and operator
  // sessions (docs/planet.md §2, "Fair shares").
  unsigned reserved_percent = 20;
  // TLS 1.3 on every connection when tls.cert_file is set; tls.ca_file verifies client
  // certificates (mutual TLS: a verified certificate's subject CN names a credential).
  util::TlsConfig tls;
  // A Hello carrying a token over plain TCP is refused unless it comes from a loopback address,
  // or this is set (the operator accepts that tokens cross the network in clear).
  bool allow_plaintext_tokens = false;
  unsigned io_threads = 2;
};

// One authenticated connection. Thread-safe.
class Session {
 public:
  virtual ~Session() = default;
  virtual uint64_t id() const = 0;                 // of this connection, unique within this server process
  virtual const Hello& hello() const = 0;          // peer_name and role as declared (token and secret cleared)
  virtual const Identity& identity() const = 0;    // who the session speaks for, as authenticated
  virtual std::string remote_address() const = 0;  // "127.0.0.1:53122"
  // Queue a frame; never blocks. Frames larger than chunk_bytes are chunked and interleaved with
  // other traffic. Returns false if the session is already closed (the frame is dropped).
  virtual bool send(Frame frame) = 0;
  // Send Goodbye{status, reason} and close. Idempotent.
  virtual void close(Status status, const std::string& reason) = 0;
};
using SessionPtr = std::shared_ptr<Session>;

class SessionHandler {
 public:
  virtual ~SessionHandler() = default;
  // After a successful handshake (Welcome already sent).
  virtual void on_open(const SessionPtr& session) = 0;
  // Every frame other than Hello, Ping, Pong, Chunk and Goodbye, fully reassembled.
  virtual void on_frame(const SessionPtr& session, Frame&& frame) = 0;
  // Exactly once per opened session: peer closed, heartbeat timeout, protocol error or stop().
  virtual void on_close(const SessionPtr& session, const std::string& reason) = 0;
};

// Whether a Hello's token may be accepted: over TLS always; over plain TCP only from a loopback
// address (127.0.0.0/8, ::1, ::ffff:127.x) unless `allow_plaintext_tokens`. `peer_host` is the
// peer's address without the port.
bool token_transport_allowed(bool tls, bool allow_plaintext_tokens, const std::string& peer_host);

// What a server holds and has refused since it started, for its metrics (docs/operations.md,
// "Monitoring"). Every name is the code's own: limits by their option's name, authentication
// failures and protocol errors by a fixed word.
struct ServerStats {
  size_t connections = 0;         // open connections, handshaking ones included
  size_t sessions = 0;            // of them, open sessions (handshake done)
  size_t resumable_sessions = 0;  // closed sessions kept resumable
  uint64_t buffered_bytes = 0;    // reassembly buffers and send queues of every session
  // By the limit that refused: max_connections, max_connections_per_address,
  // max_sessions_per_credential, max_buffered_bytes(_per_credential), max_send_queue_bytes,
  // max_hello_bytes, chunk_bytes, max_message_bytes, max_reassembly_bytes, max_partial_messages,
  // handshake_timeout.
  std::vector<std::pair<std::string, uint64_t>> refusals;
  // Handshakes refused for their credential: wrong_token, unknown_certificate, token_required,
  // plaintext_token, role_not_granted.
  std::vector<std::pair<std::string, uint64_t>> authentication_failures;
  // Connections closed for what they sent: a ProtocolErrorCode's name, or BAD_HELLO (version,
  // peer name, role number), UNEXPECTED_FRAME.
  std::vector<std::pair<std::string, uint64_t>> protocol_errors;
};

class Server {
 public:
  // Binds and listens; throws std::runtime_error naming the address on failure.
  Server(ServerOptions options, SessionHandler& handler);
  ~Server();  // stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  uint16_t port() const;  // the bound port (useful with port 0)
  // The connection limit in force: ServerOptions::max_connections, or less if the descriptors
  // left to the process at construction do not allow as many.
  size_t max_connections() const;
  void start();  // starts the I/O threads
  void stop();   // closes every session (on_close called), joins the threads; idempotent

  // Replaces the authenticator (e.g. credentials re-read on SIGHUP) for the handshakes that
  // follow. Open sessions whose credential is gone or changed are closed with Goodbye
  // UNAUTHENTICATED and their sessions are no longer resumable; the others keep going. Returns
  // how many sessions were closed. Thread-safe; not from an I/O thread.
  size_t set_authenticator(std::shared_ptr<const Authenticator> authenticator);
  // Re-reads the TLS certificate, key and client CAs (e.g. renewed, on SIGHUP) for the
  // connections accepted from now on; open ones keep theirs. Throws std::invalid_argument naming
  // the file that cannot be loaded (the previous settings stay), std::logic_error on a plain-TCP
  // server. Thread-safe.
  void reload_tls(const util::TlsConfig& tls);

  // Thread-safe; takes the server's locks briefly.
  ServerStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace urs::planet
