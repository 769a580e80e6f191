#pragma once
// Where a CAMUS server's credentials come from: a credentials file (YAML, re-read on SIGHUP)
// and/or the single token of --token-file, given a name and a role explicitly.
//
//   credentials:
//     - name: sam-robot1          # letters, digits and . _ - @ : (at most 64)
//       role: sam                 # client | sam | operator
//       token_sha256: 9f86d0...   # SHA-256 of the token: printf %s "$TOKEN" | sha256sum
//     - name: bridge-kr
//       role: operator
//       token_file: bridge-kr.token   # the token itself, hashed when read (relative: to this file)
//     - name: alice
//       role: operator
//       certificate: alice.kr.example # mutual TLS: the verified client-certificate name
//
// Each credential has token_sha256 or token_file (not both), a certificate, or both.

#include <memory>
#include <optional>
#include <string>

#include "urs/planet/credentials.hpp"

namespace urs::camus_server {

struct CredentialSources {
  std::string credentials_file;                        // --credentials; empty = none
  std::string token_file;                              // --token-file; empty = none
  std::string token_name = "space";                    // --token-name: the name the single token authenticates as
  planet::Role token_role = planet::ROLE_UNSPECIFIED;  // --token-role (required with --token-file)

  bool any() const { return !credentials_file.empty() || !token_file.empty(); }
};

// Reads every source into one set of credentials; null when there is none (an open server).
// Throws util::ConfigError naming the file and listing every problem with its key
// ("credentials[2].role: 'admin' is not client, sam or operator").
std::shared_ptr<const planet::Credentials> load_credentials(const CredentialSources& sources);

// "client" / "sam" / "operator" -> the role; ROLE_UNSPECIFIED for anything else.
planet::Role parse_role(const std::string& word);

}  // namespace urs::camus_server
