#pragma once
// Planet server transport: accepts TCP connections, performs the versioned, authenticated
// handshake, answers heartbeats, reassembles chunked messages and hands every other frame to a
// SessionHandler. It knows nothing of services, events or routing (that is the CAMUS server's).
//
// Threading: all handler callbacks run on the server's I/O threads and must not block; hand slow
// work to another thread and answer later through Session::send, which is thread-safe.

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "planet.pb.h"

namespace urs::planet {

struct ServerOptions {
  std::string host = "0.0.0.0";
  uint16_t port = 0;  // 0 = ephemeral; read back with Server::port()
  std::string space;  // announced in Welcome
  std::string token;  // required in Hello when non-empty
  std::chrono::milliseconds heartbeat_interval{1000};
  std::chrono::milliseconds heartbeat_timeout{3000};    // silent peer is closed after this
  std::chrono::milliseconds handshake_timeout{5000};    // Hello must arrive within this
  uint64_t max_message_bytes = 64ull << 20;             // largest reassembled message accepted
  uint32_t chunk_bytes = 64u << 10;                     // larger frames are sent as chunks
  size_t max_send_queue_bytes = 256ull << 20;           // per session; beyond it the session is closed
  unsigned io_threads = 2;
};

// One authenticated connection. Thread-safe.
class Session {
 public:
  virtual ~Session() = default;
  virtual uint64_t id() const = 0;                   // unique within this server process
  virtual const Hello& hello() const = 0;     // peer_name, role, session_id (token cleared)
  virtual std::string remote_address() const = 0;    // "127.0.0.1:53122"
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

class Server {
 public:
  // Binds and listens; throws std::runtime_error naming the address on failure.
  Server(ServerOptions options, SessionHandler& handler);
  ~Server();  // stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  uint16_t port() const;  // the bound port (useful with port 0)
  void start();           // starts the I/O threads
  void stop();            // closes every session (on_close called), joins the threads; idempotent

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace urs::planet
