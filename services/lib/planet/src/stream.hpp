#pragma once
// The byte stream under a Planet Link: plain TCP or TLS 1.3 over TCP (OpenSSL with memory BIOs,
// its SSL object under a mutex). The Link's framing, queues, heartbeats and close are the same
// for both; only how bytes move differs. Either lets the thread that queues a frame write it
// straight to the socket (send_now, non-blocking), so a small call costs no hop to the strand.
// One a file: stream.cpp (TCP), tls_stream.cpp (TLS), tls_context.cpp (the TLS contexts).
//
// Threading: every asynchronous operation is started from the Link's strand (the socket's
// executor); at most one read and one write are in flight at a time, and the writes (send_now,
// async_write) are made by one writer at a time (the Link's batch owner).

#include <sys/uio.h>

#include <asio.hpp>
#include <asio/ssl.hpp>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "urs/util/tls.hpp"

namespace urs::planet::detail {

class Stream {
 public:
  using Handler = std::function<void(const std::error_code&, size_t)>;
  virtual ~Stream() = default;

  // The TCP socket under the stream (endpoints, options, shutdown and close).
  virtual asio::ip::tcp::socket& socket() = 0;
  virtual bool secure() const = 0;
  // TLS: the handshake, before anything is read or written. Plain TCP: completes at once.
  virtual void async_handshake(std::function<void(const std::error_code&)> handler) = 0;
  virtual void async_read_some(asio::mutable_buffer buffer, Handler handler) = 0;
  // Writes all of `buffers` (they stay valid until the handler runs), and whatever send_now left.
  virtual void async_write(const std::vector<asio::const_buffer>& buffers, Handler handler) = 0;
  // Writes what the socket takes now without blocking, from any thread (by the one writer):
  // returns the bytes of `iov` taken (0: the socket is full), or -1 with `error` set.
  virtual long send_now(const iovec* iov, size_t count, std::error_code& error) = 0;
  // TLS: send_now took the bytes but the socket did not take all of their encryption yet; an
  // async_write (with no buffers) writes the rest.
  virtual bool has_pending_output() const { return false; }
  // The subject CN of the peer's certificate once the TLS handshake verified it; empty otherwise.
  virtual std::string peer_certificate_name() const { return {}; }
};

std::unique_ptr<Stream> make_tcp_stream(asio::ip::tcp::socket socket);

// `context` from make_server_tls_context / make_client_tls_context; `server_name` (client only)
// is sent as SNI and checked against the server's certificate.
std::unique_ptr<Stream> make_tls_stream(asio::ip::tcp::socket socket, std::shared_ptr<asio::ssl::context> context,
                                        bool server, const std::string& server_name = "");

// TLS 1.3 only. Throw std::invalid_argument naming the file that could not be loaded.
std::shared_ptr<asio::ssl::context> make_server_tls_context(const util::TlsConfig& tls);
std::shared_ptr<asio::ssl::context> make_client_tls_context(const util::TlsConfig& tls);

}  // namespace urs::planet::detail
