// The TLS 1.3 contexts of Planet's servers and clients (stream.hpp: make_server_tls_context,
// make_client_tls_context).
#include <openssl/ssl.h>

#include <stdexcept>
#include <string>

#include "stream.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/files.hpp"

namespace urs::planet::detail {
namespace {

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
  load("TLS certificate", tls.cert_file,
       [&](std::error_code& e) { context.use_certificate_chain_file(tls.cert_file, e); });
  load("TLS private key", tls.key_file,
       [&](std::error_code& e) { context.use_private_key_file(tls.key_file, asio::ssl::context::pem, e); });
  if (SSL_CTX_check_private_key(context.native_handle()) != 1) {
    throw std::invalid_argument("TLS private key '" + tls.key_file + "' does not match certificate '" + tls.cert_file +
                                "'");
  }
}

// A file the server reads at start and again on SIGHUP: a regular file of at most 1 MiB, read
// without ever blocking (util::read_regular_file), then handed to OpenSSL from memory.
std::string server_file(const char* what, const std::string& path) {
  try {
    return util::read_regular_file(path, util::kMaxReloadFileBytes);
  } catch (const util::ConfigError& e) {
    throw std::invalid_argument(std::string(what) + " '" + path + "' cannot be loaded: " + e.what());
  }
}

void load_server_identity(asio::ssl::context& context, const util::TlsConfig& tls) {
  const std::string certificate = server_file("TLS certificate", tls.cert_file);
  const std::string key = server_file("TLS private key", tls.key_file);
  load("TLS certificate", tls.cert_file,
       [&](std::error_code& e) { context.use_certificate_chain(asio::buffer(certificate), e); });
  load("TLS private key", tls.key_file,
       [&](std::error_code& e) { context.use_private_key(asio::buffer(key), asio::ssl::context::pem, e); });
  if (SSL_CTX_check_private_key(context.native_handle()) != 1) {
    throw std::invalid_argument("TLS private key '" + tls.key_file + "' does not match certificate '" + tls.cert_file +
                                "'");
  }
}

}  // namespace

std::shared_ptr<asio::ssl::context> make_server_tls_context(const util::TlsConfig& tls) {
  auto context = tls13_context(asio::ssl::context::tls_server);
  load_server_identity(*context, tls);
  if (!tls.ca_file.empty()) {
    const std::string authorities = server_file("TLS client CA file", tls.ca_file);
    load("TLS client CA file", tls.ca_file,
         [&](std::error_code& e) { context->add_certificate_authority(asio::buffer(authorities), e); });
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
