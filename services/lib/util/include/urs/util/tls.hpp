#pragma once
// TLS settings of a Planet endpoint and the command-line flags that fill them, shared by every
// program (one implementation): the server's --tls-cert/--tls-key/--tls-client-ca, the clients'
// --tls/--tls-ca/--tls-cert/--tls-key. Header-only for the flags (CLI11 is header-only too; the
// App type is a template parameter so that this library does not depend on it).

#include <string>

namespace urs::util {

struct TlsConfig {
  bool enabled = false;     // TLS 1.3 on every connection (server: when cert_file is set)
  std::string ca_file;      // client: CAs that verify the server (empty: the system's);
                            // server: CAs that verify client certificates (empty: no mutual TLS)
  std::string cert_file;    // PEM certificate chain: the server's (required), or the client's (mutual TLS)
  std::string key_file;     // PEM private key of cert_file
  std::string server_name;  // client: the name the server certificate must carry (empty: the host)
};

// Throws ConfigError naming the flag if a file is unreadable or cert and key come apart; a client
// given --tls-ca or --tls-cert speaks TLS (enabled is set). --tls-ca may come from env URS_TLS_CA.
void check_tls_client(TlsConfig& tls);
void check_tls_server(TlsConfig& tls);

template <typename App>
void add_tls_client_flags(App& app, TlsConfig& tls) {
  app.add_flag("--tls", tls.enabled, "Speak TLS 1.3 to the server (implied by --tls-ca and --tls-cert)");
  app.add_option("--tls-ca", tls.ca_file,
                 "PEM file of the CA(s) that sign the server's certificate (default: the system's; env URS_TLS_CA)")
      ->envname("URS_TLS_CA");
  app.add_option("--tls-cert", tls.cert_file, "PEM client certificate for mutual TLS (with --tls-key)");
  app.add_option("--tls-key", tls.key_file, "PEM private key of --tls-cert");
  app.add_option("--tls-server-name", tls.server_name,
                 "Name the server's certificate must carry (default: the host of --server)");
}

template <typename App>
void add_tls_server_flags(App& app, TlsConfig& tls) {
  app.add_option("--tls-cert", tls.cert_file, "PEM certificate chain of this server: every connection is TLS 1.3");
  app.add_option("--tls-key", tls.key_file, "PEM private key of --tls-cert");
  app.add_option("--tls-client-ca", tls.ca_file,
                 "PEM CA(s) for client certificates (mutual TLS: a verified certificate's subject CN names a "
                 "credential by its certificate: field)");
}

}  // namespace urs::util
