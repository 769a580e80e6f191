#pragma once
// Who a Planet session speaks for. The server decides it at the handshake from what it verified
// (a token, a client certificate), never from what the peer declares (Hello.peer_name).

#include <cstdint>
#include <string>

#include "planet.pb.h"

namespace urs::planet {

// Name of every session on a server that has no credentials (an open space).
inline constexpr const char* kAnonymousIdentity = "anonymous";

// The authenticated identity of an open session.
struct Identity {
  std::string name;         // the credential's name (kAnonymousIdentity on an open server)
  Role role = CLIENT;       // what the session may do: CLIENT < SAM < OPERATOR
  uint64_t session = 0;     // the resumable session: the same across the reconnects that
                            // presented its Welcome.session_secret; unique in the server process
  std::string fingerprint;  // of the credential as admitted; changes when the operator changes it
};

// The outcome of checking a Hello's credential.
struct Admission {
  Status status = Status::OK;  // OK or UNAUTHENTICATED
  std::string reason;          // why, when refused (goes into Refused.reason: no secret in it)
  std::string name;            // OK: the credential's name
  Role role = CLIENT;          // OK: the credential's role
  std::string fingerprint;     // OK: see Identity::fingerprint

  bool ok() const { return status == Status::OK; }
};

// Decides who a Hello speaks for. Implementations are immutable and thread-safe; the server swaps
// in a new one to reload (Server::set_authenticator).
class Authenticator {
 public:
  virtual ~Authenticator() = default;
  // `token` is Hello.token; `certificate` the verified client-certificate name (empty without
  // one). Takes time that does not depend on which credential, if any, the token matches.
  virtual Admission admit(const std::string& token, const std::string& certificate) const = 0;
  // The fingerprint credential `name` has now; empty if there is no such credential.
  virtual std::string fingerprint(const std::string& name) const = 0;
};

// "client", "sam", "operator" (lower case, as in credentials files); "none" otherwise.
inline const char* role_word(Role role) {
  switch (role) {
    case CLIENT:
      return "client";
    case SAM:
      return "sam";
    case OPERATOR:
      return "operator";
    default:
      return "none";
  }
}

}  // namespace urs::planet
