#include "urs/util/tls.hpp"

#include <fstream>

#include "urs/util/cli.hpp"

namespace urs::util {
namespace {

void readable(const std::string& path, const char* flag) {
  if (path.empty()) return;
  std::ifstream in(path);
  if (!in) throw ConfigError(std::string(flag) + ": '" + path + "' cannot be read");
}

void check_files(const TlsConfig& tls, const char* ca_flag) {
  if (tls.cert_file.empty() != tls.key_file.empty()) {
    throw ConfigError("--tls-cert and --tls-key go together: give both or neither");
  }
  readable(tls.ca_file, ca_flag);
  readable(tls.cert_file, "--tls-cert");
  readable(tls.key_file, "--tls-key");
}

}  // namespace

void check_tls_client(TlsConfig& tls) {
  check_files(tls, "--tls-ca");
  if (!tls.ca_file.empty() || !tls.cert_file.empty() || !tls.server_name.empty()) tls.enabled = true;
}

void check_tls_server(TlsConfig& tls) {
  check_files(tls, "--tls-client-ca");
  if (!tls.ca_file.empty() && tls.cert_file.empty()) {
    throw ConfigError("--tls-client-ca needs --tls-cert and --tls-key: mutual TLS is TLS");
  }
  tls.enabled = !tls.cert_file.empty();
}

}  // namespace urs::util
