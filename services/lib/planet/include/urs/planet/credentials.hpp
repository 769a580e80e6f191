#pragma once
// A space's named credentials: each a name, a role, and how it is proven (a token, stored only
// as its SHA-256, and/or a verified client-certificate name for mutual TLS). The Authenticator
// of a Planet server that has any. Immutable and thread-safe once built.

#include <string>
#include <vector>

#include "urs/planet/authenticator.hpp"

namespace urs::planet {

struct Credential {
  std::string name;  // [A-Za-z0-9._@:-], 1..64 characters; not "camus-server" or "anonymous"
  Role role = CLIENT;
  std::string token_sha256;  // SHA-256 of the token, 64 hex digits; empty = no token
  std::string certificate;   // client-certificate name (subject CN) mapped to it; empty = none
};

class Credentials final : public Authenticator {
 public:
  // Throws std::invalid_argument listing every problem, each naming the credential: a bad or
  // reserved or repeated name, a role other than CLIENT/SAM/OPERATOR, a hash that is not 64 hex
  // digits, two credentials with the same token or certificate, one with neither.
  explicit Credentials(std::vector<Credential> credentials);

  // Authenticator. A token, when given, decides (the certificate is then not consulted).
  Admission admit(const std::string& token, const std::string& certificate) const override;
  std::string fingerprint(const std::string& name) const override;

  const std::vector<Credential>& all() const { return credentials_; }

  // Empty if `name` may name a credential, else why not.
  static std::string name_problem(const std::string& name);

 private:
  std::vector<Credential> credentials_;
};

}  // namespace urs::planet
