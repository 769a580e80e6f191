// The TLS 1.3 Stream (stream.hpp: make_tls_stream).
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <sys/socket.h>

#include <array>
#include <cerrno>
#include <climits>
#include <mutex>
#include <stdexcept>

#include "stream.hpp"

namespace urs::planet::detail {
namespace {

// TLS 1.3 over the TCP socket with OpenSSL driven through memory BIOs: the SSL object is used
// under a mutex, so that a frame can be encrypted and written straight to the socket by the
// thread that queues it (as on plain TCP), while the strand reads.
class TlsStream final : public Stream {
 public:
  TlsStream(asio::ip::tcp::socket socket, std::shared_ptr<asio::ssl::context> context, bool server,
            const std::string& server_name)
      : context_(std::move(context)), socket_(std::move(socket)) {
    ssl_ = SSL_new(context_->native_handle());
    if (ssl_ == nullptr) throw std::runtime_error("SSL_new failed");
    BIO* in = BIO_new(BIO_s_mem());
    BIO* out = BIO_new(BIO_s_mem());
    BIO_set_mem_eof_return(in, -1);
    BIO_set_mem_eof_return(out, -1);
    SSL_set_bio(ssl_, in, out);  // owned by ssl_
    in_ = in;
    out_ = out;
    if (server) {
      SSL_set_accept_state(ssl_);
      return;
    }
    SSL_set_connect_state(ssl_);
    if (server_name.empty()) return;
    // The name the server's certificate must carry: an IP address, or a DNS name (also sent as SNI).
    std::error_code not_ip;
    asio::ip::make_address(server_name, not_ip);
    if (!not_ip) {
      X509_VERIFY_PARAM_set1_ip_asc(SSL_get0_param(ssl_), server_name.c_str());
    } else {
      SSL_set1_host(ssl_, server_name.c_str());
      SSL_set_tlsext_host_name(ssl_, server_name.c_str());
    }
  }
  ~TlsStream() override { SSL_free(ssl_); }

  asio::ip::tcp::socket& socket() override { return socket_; }
  bool secure() const override { return true; }

  void async_handshake(std::function<void(const std::error_code&)> handler) override {
    int result = 0;
    std::error_code error;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ERR_clear_error();
      result = SSL_do_handshake(ssl_);
      if (result != 1 && SSL_get_error(ssl_, result) != SSL_ERROR_WANT_READ) error = error_locked(result);
      take_output_locked();
    }
    flush_async([this, result, error, handler = std::move(handler)](const std::error_code& write_error) mutable {
      if (write_error || error || result == 1) {
        handler(write_error ? write_error : error);
        return;
      }
      read_raw([this, handler = std::move(handler)](const std::error_code& read_error) mutable {
        if (read_error) {
          handler(read_error);
          return;
        }
        async_handshake(std::move(handler));
      });
    });
  }

  void async_read_some(asio::mutable_buffer buffer, Handler handler) override {
    read_some(buffer, std::move(handler), /*in_completion=*/false);
  }

  // Decrypts what is buffered into `buffer`; when nothing is, reads the socket first. The handler
  // runs at once when this is already a completion on the strand, else it is posted.
  void read_some(asio::mutable_buffer buffer, Handler handler, bool in_completion) {
    int result = 0;
    std::error_code error;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ERR_clear_error();
      result = SSL_read(ssl_, buffer.data(), static_cast<int>(std::min<size_t>(buffer.size(), INT_MAX)));
      if (result <= 0 && SSL_get_error(ssl_, result) != SSL_ERROR_WANT_READ) error = error_locked(result);
    }
    if (result > 0 || error) {
      const size_t size = result > 0 ? static_cast<size_t>(result) : 0;
      if (in_completion) {
        handler(error, size);
      } else {
        asio::post(socket_.get_executor(), [handler = std::move(handler), error, size] { handler(error, size); });
      }
      return;
    }
    read_raw([this, buffer, handler = std::move(handler)](const std::error_code& read_error) mutable {
      if (read_error) {
        handler(read_error, 0);
        return;
      }
      read_some(buffer, std::move(handler), /*in_completion=*/true);
    });
  }

  long send_now(const iovec* iov, size_t count, std::error_code& error) override {
    std::lock_guard<std::mutex> lock(mutex_);
    size_t taken = 0;
    if (!encrypt_locked(iov, count, taken, error)) return -1;
    // What the socket takes now; the rest stays in cipher_ for flush_async (has_pending_output).
    while (cipher_sent_ < cipher_.size()) {
      const ssize_t sent = ::send(socket_.native_handle(), cipher_.data() + cipher_sent_, cipher_.size() - cipher_sent_,
                                  MSG_DONTWAIT | MSG_NOSIGNAL);
      if (sent < 0) {
        if (errno == EINTR) continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK) {
          error = std::error_code(errno, std::system_category());
          return -1;
        }
        break;
      }
      cipher_sent_ += static_cast<size_t>(sent);
    }
    if (cipher_sent_ == cipher_.size()) {
      cipher_.clear();
      cipher_sent_ = 0;
    }
    return static_cast<long>(taken);
  }

  bool has_pending_output() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return cipher_sent_ < cipher_.size() || BIO_ctrl_pending(out_) > 0;
  }

  void async_write(const std::vector<asio::const_buffer>& buffers, Handler handler) override {
    std::vector<iovec> iov;
    size_t total = 0;
    for (const auto& buffer : buffers) {
      iov.push_back({const_cast<void*>(buffer.data()), buffer.size()});
      total += buffer.size();
    }
    std::error_code error;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      size_t taken = 0;
      encrypt_locked(iov.data(), iov.size(), taken, error);
    }
    if (error) {
      asio::post(socket_.get_executor(), [handler = std::move(handler), error] { handler(error, 0); });
      return;
    }
    flush_async([handler = std::move(handler), total](const std::error_code& write_error) {
      handler(write_error, write_error ? 0 : total);
    });
  }

  std::string peer_certificate_name() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (SSL_get_verify_result(ssl_) != X509_V_OK) return {};
    X509* certificate = SSL_get1_peer_certificate(ssl_);
    if (certificate == nullptr) return {};
    char name[256] = {};
    const int size = X509_NAME_get_text_by_NID(X509_get_subject_name(certificate), NID_commonName, name, sizeof name);
    X509_free(certificate);
    return size > 0 ? std::string(name, static_cast<size_t>(size)) : std::string();
  }

 private:
  // With mutex_ held, after an SSL call that returned `result` and did not just want more input.
  std::error_code error_locked(int result) {
    const int kind = SSL_get_error(ssl_, result);
    if (kind == SSL_ERROR_ZERO_RETURN) return asio::error::eof;  // close_notify
    const unsigned long code = ERR_get_error();
    if (code == 0) return asio::ssl::error::stream_truncated;
    return std::error_code(static_cast<int>(code), asio::error::get_ssl_category());
  }

  // With mutex_ held: encrypts `iov` (as one write: records of up to 16 KiB) into cipher_.
  bool encrypt_locked(const iovec* iov, size_t count, size_t& taken, std::error_code& error) {
    plain_.clear();
    for (size_t i = 0; i < count; ++i) plain_.append(static_cast<const char*>(iov[i].iov_base), iov[i].iov_len);
    if (!plain_.empty()) {
      ERR_clear_error();
      const int result = SSL_write(ssl_, plain_.data(), static_cast<int>(plain_.size()));
      if (result <= 0) {
        error = error_locked(result);
        return false;
      }
    }
    taken = plain_.size();
    take_output_locked();
    return true;
  }

  // With mutex_ held: moves what OpenSSL wrote into its output BIO to cipher_.
  void take_output_locked() {
    char block[16384];
    for (;;) {
      const int got = BIO_read(out_, block, sizeof block);
      if (got <= 0) break;
      cipher_.append(block, static_cast<size_t>(got));
    }
  }

  // Writes everything pending (cipher_ and the output BIO) to the socket, then calls `done`. By
  // the one writer at a time (the Link's batch owner, or the handshake).
  void flush_async(std::function<void(const std::error_code&)> done) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      take_output_locked();
      staging_.assign(cipher_, cipher_sent_, std::string::npos);
      cipher_.clear();
      cipher_sent_ = 0;
    }
    if (staging_.empty()) {
      done({});
      return;
    }
    asio::async_write(socket_, asio::buffer(staging_),
                      [this, done = std::move(done)](const std::error_code& error, size_t) mutable {
                        if (error) {
                          done(error);
                          return;
                        }
                        flush_async(std::move(done));
                      });
  }

  // Reads what the socket has into the input BIO.
  void read_raw(std::function<void(const std::error_code&)> done) {
    socket_.async_read_some(asio::buffer(raw_),
                            [this, done = std::move(done)](const std::error_code& error, size_t size) {
                              if (!error) {
                                std::lock_guard<std::mutex> lock(mutex_);
                                BIO_write(in_, raw_.data(), static_cast<int>(size));
                              }
                              done(error);
                            });
  }

  std::shared_ptr<asio::ssl::context> context_;  // outlives ssl_
  asio::ip::tcp::socket socket_;
  mutable std::mutex mutex_;  // guards ssl_ (and its BIOs), cipher_, plain_
  SSL* ssl_ = nullptr;
  BIO* in_ = nullptr;   // network → OpenSSL
  BIO* out_ = nullptr;  // OpenSSL → network
  std::string plain_;   // a batch's plaintext, in one piece
  std::string cipher_;  // encrypted, not yet written
  size_t cipher_sent_ = 0;
  std::string staging_;              // being written by flush_async
  std::array<char, 17 * 1024> raw_;  // strand: one read from the socket
};

}  // namespace

std::unique_ptr<Stream> make_tls_stream(asio::ip::tcp::socket socket, std::shared_ptr<asio::ssl::context> context,
                                        bool server, const std::string& server_name) {
  return std::make_unique<TlsStream>(std::move(socket), std::move(context), server, server_name);
}

}  // namespace urs::planet::detail
