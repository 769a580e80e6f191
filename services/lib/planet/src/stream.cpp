#include "stream.hpp"

#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>

#include <stdexcept>

namespace urs::planet::detail {
namespace {

class TcpStream final : public Stream {
 public:
  explicit TcpStream(asio::ip::tcp::socket socket) : socket_(std::move(socket)) {}

  asio::ip::tcp::socket& socket() override { return socket_; }
  bool direct_writes() const override { return true; }
  bool secure() const override { return false; }
  void async_handshake(std::function<void(const std::error_code&)> handler) override {
    asio::post(socket_.get_executor(), [handler = std::move(handler)] { handler(std::error_code()); });
  }
  void async_read_some(asio::mutable_buffer buffer, Handler handler) override {
    socket_.async_read_some(buffer, std::move(handler));
  }
  void async_write(const std::vector<asio::const_buffer>& buffers, Handler handler) override {
    asio::async_write(socket_, buffers, std::move(handler));
  }

 private:
  asio::ip::tcp::socket socket_;
};

class TlsStream final : public Stream {
 public:
  TlsStream(asio::ip::tcp::socket socket, std::shared_ptr<asio::ssl::context> context, bool server,
            const std::string& server_name)
      : context_(std::move(context)), stream_(std::move(socket), *context_), server_(server) {
    if (!server_ && !server_name.empty()) {
      // SNI, and the name the server's certificate must carry (DNS name or IP address).
      SSL_set_tlsext_host_name(stream_.native_handle(), server_name.c_str());
      stream_.set_verify_callback(asio::ssl::host_name_verification(server_name));
    }
  }

  asio::ip::tcp::socket& socket() override { return stream_.next_layer(); }
  bool direct_writes() const override { return false; }
  bool secure() const override { return true; }
  void async_handshake(std::function<void(const std::error_code&)> handler) override {
    stream_.async_handshake(server_ ? asio::ssl::stream_base::server : asio::ssl::stream_base::client,
                            std::move(handler));
  }
  void async_read_some(asio::mutable_buffer buffer, Handler handler) override {
    stream_.async_read_some(buffer, std::move(handler));
  }
  void async_write(const std::vector<asio::const_buffer>& buffers, Handler handler) override {
    // One contiguous buffer: TLS records of up to 16 KiB instead of one record per small piece.
    staging_.clear();
    for (const auto& buffer : buffers) staging_.append(static_cast<const char*>(buffer.data()), buffer.size());
    asio::async_write(stream_, asio::buffer(staging_), std::move(handler));
  }
  std::string peer_certificate_name() const override {
    SSL* ssl = const_cast<asio::ssl::stream<asio::ip::tcp::socket>&>(stream_).native_handle();
    if (SSL_get_verify_result(ssl) != X509_V_OK) return {};
    X509* certificate = SSL_get1_peer_certificate(ssl);
    if (certificate == nullptr) return {};
    char name[256] = {};
    const int size = X509_NAME_get_text_by_NID(X509_get_subject_name(certificate), NID_commonName, name, sizeof name);
    X509_free(certificate);
    return size > 0 ? std::string(name, static_cast<size_t>(size)) : std::string();
  }

 private:
  std::shared_ptr<asio::ssl::context> context_;  // outlives stream_
  asio::ssl::stream<asio::ip::tcp::socket> stream_;
  const bool server_;
  std::string staging_;
};

std::shared_ptr<asio::ssl::context> tls13_context(asio::ssl::context::method method) {
  auto context = std::make_shared<asio::ssl::context>(method);
  SSL_CTX_set_min_proto_version(context->native_handle(), TLS1_3_VERSION);
  context->set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_compression);
  return context;
}

template <typename Load>
void load(const char* what, const std::string& path, Load&& fn) {
  std::error_code error;
  fn(error);
  if (error) throw std::invalid_argument(std::string(what) + " '" + path + "' cannot be loaded: " + error.message());
}

void load_identity(asio::ssl::context& context, const util::TlsConfig& tls) {
  load("TLS certificate", tls.cert_file, [&](std::error_code& e) { context.use_certificate_chain_file(tls.cert_file, e); });
  load("TLS private key", tls.key_file,
       [&](std::error_code& e) { context.use_private_key_file(tls.key_file, asio::ssl::context::pem, e); });
  if (SSL_CTX_check_private_key(context.native_handle()) != 1) {
    throw std::invalid_argument("TLS private key '" + tls.key_file + "' does not match certificate '" +
                                tls.cert_file + "'");
  }
}

}  // namespace

std::unique_ptr<Stream> make_tcp_stream(asio::ip::tcp::socket socket) {
  return std::make_unique<TcpStream>(std::move(socket));
}

std::unique_ptr<Stream> make_tls_stream(asio::ip::tcp::socket socket, std::shared_ptr<asio::ssl::context> context,
                                        bool server, const std::string& server_name) {
  return std::make_unique<TlsStream>(std::move(socket), std::move(context), server, server_name);
}

std::shared_ptr<asio::ssl::context> make_server_tls_context(const util::TlsConfig& tls) {
  auto context = tls13_context(asio::ssl::context::tls_server);
  load_identity(*context, tls);
  if (!tls.ca_file.empty()) {
    load("TLS client CA file", tls.ca_file, [&](std::error_code& e) { context->load_verify_file(tls.ca_file, e); });
    // Mutual TLS is optional per connection: a client without a certificate may still present a
    // token; one with a certificate that does not verify is refused in the handshake.
    context->set_verify_mode(asio::ssl::verify_peer);
  } else {
    context->set_verify_mode(asio::ssl::verify_none);
  }
  return context;
}

std::shared_ptr<asio::ssl::context> make_client_tls_context(const util::TlsConfig& tls) {
  auto context = tls13_context(asio::ssl::context::tls_client);
  if (tls.ca_file.empty()) {
    context->set_default_verify_paths();
  } else {
    load("TLS CA file", tls.ca_file, [&](std::error_code& e) { context->load_verify_file(tls.ca_file, e); });
  }
  context->set_verify_mode(asio::ssl::verify_peer);
  if (!tls.cert_file.empty()) load_identity(*context, tls);
  return context;
}

}  // namespace urs::planet::detail
