#pragma once
// A program's Planet client options from its flags: --server, --token-file and the TLS client flags
// (urs/util/tls.hpp). Header-only.

#include <string>

#include "urs/planet/client.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/tls.hpp"

namespace urs::planet {

// Options reaching `server` ("HOST:PORT", flag --server) with the token read from `token_file`
// ("" for none) over `tls` (checked by util::check_tls_client). The rest keeps its defaults.
// Throws util::ConfigError naming the flag or file and the reason.
inline ClientOptions client_options_from(const std::string& server, const std::string& token_file,
                                         util::TlsConfig tls) {
  const util::Endpoint endpoint = util::parse_endpoint(server, "--server");
  ClientOptions options;
  options.host = endpoint.host;
  options.port = endpoint.port;
  options.token = util::read_token_file(token_file);
  util::check_tls_client(tls);
  options.tls = tls;
  return options;
}

}  // namespace urs::planet
