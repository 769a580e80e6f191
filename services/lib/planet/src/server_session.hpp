#pragma once
// One accepted connection of the Planet server: the Hello/Welcome handshake (version, peer name,
// token transport, credential, role, session resumption), then its frames to the SessionHandler.

#include <asio.hpp>
#include <atomic>
#include <memory>
#include <string>

#include "link.hpp"
#include "server_core.hpp"
#include "urs/planet/server.hpp"

namespace urs::planet {

class ServerSession final : public detail::Link, public Session {
 public:
  // `io` runs `stream`'s socket (one of the server's io_contexts).
  ServerSession(ServerCore& server, std::shared_ptr<asio::io_context> io, uint64_t id,
                std::unique_ptr<detail::Stream> stream, const detail::LinkConfig& config, std::string source_address)
      : Link(std::move(io), std::move(stream), config),
        server_(server),
        id_(id),
        source_address_(std::move(source_address)),
        handshake_timer_(executor()) {}

  // The peer's address without the port (what max_connections_per_address counts).
  const std::string& source_address() const { return source_address_; }

  // Starts the handshake timer and the read loop.
  void begin();

  // Only after the io threads are gone (Server::stop fallback).
  void abandon(const std::string& reason) { finish(reason); }

  // The handshake succeeded: hello() and identity() are set and will not change.
  bool is_open() const { return opened_; }

  // Session
  uint64_t id() const override { return id_; }
  const Hello& hello() const override { return hello_; }
  const Identity& identity() const override { return identity_; }
  std::string remote_address() const override { return peer_address(); }
  bool send(Frame frame) override { return enqueue(std::move(frame)); }
  void close(Status status, const std::string& reason) override {
    close_link(detail::make_goodbye(status, reason), reason);
  }

 protected:
  // Link
  void handle_frame(Frame&& frame) override;
  void handle_closed(const std::string& reason) override;
  std::string describe() const override;
  void handle_protocol_error(const ProtocolError& error) override;
  void handle_send_queue_full() override { server_.refusals.count("max_send_queue_bytes"); }

 private:
  SessionPtr self() { return std::static_pointer_cast<ServerSession>(shared_from_this()); }

  void protocol_violation(const std::string& reason);

  // The peer's declared name is quoted only once it is known to be printable and short.
  void refuse(Status status, const std::string& reason, const Hello& hello);
  // refuse(), counted as an authentication failure for `why` (ServerStats).
  void refuse_credential(const char* why, Status status, const std::string& reason, const Hello& hello);
  // refuse(), counted as a BAD_HELLO protocol error.
  void refuse_hello(Status status, const std::string& reason, const Hello& hello);

  // The verified client-certificate name; empty on a connection without one (plain TCP).
  std::string certificate_name() const { return peer_certificate_name(); }

  void handshake(Frame&& frame);

  ServerCore& server_;
  const uint64_t id_;
  const std::string source_address_;
  asio::steady_timer handshake_timer_;
  // Strand: a Publish whose id the session this one continues has received answers itself.
  bool refuse_resent_publish(const Publish& publish);

  Hello hello_;                      // written once on the strand before on_open; read-only afterwards
  Identity identity_;                // likewise
  std::atomic<bool> opened_{false};  // set on the strand after hello_; read anywhere
  ShareHolder holder_;               // identity_ as its budgets count it (set with it)
  // Strand: the highest Publish.publish_id received; and, when the Hello presented the secret of
  // a session the server forgot, that session and the highest id it had received.
  uint64_t publish_through_ = 0;
  uint64_t forgotten_session_ = 0;
  uint64_t forgotten_publish_through_ = 0;
};

}  // namespace urs::planet
