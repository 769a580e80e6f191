#pragma once
// Logins: who may see and who may act through the gateway (docs/dashboard.md, "Security").
//
// A person logs in with a credential of the space. In a space with a CAMUS server the gateway
// proves it the way any client does: it opens a Planet session of its own with that credential,
// and the server accepts or refuses it; the session then carries that person's calls, so the
// server decides what they may do. In a space without one (RT only) the credential is compared
// with the space's token given to the gateway (--token-file). Roles:
//   operator  a credential the CAMUS server gives the role operator (its Welcome says so), or,
//             without a server, the space's token; never when read_only
//   viewer    any other credential the server accepts (roles client and sam), the viewer
//             credential (--viewer-token-file), and every login when read_only
// A login is a random 128-bit id (the dashboard's cookie, or ?session= in a Foxglove URL); it
// ends when logged out or idle too long. Credentials are never logged nor kept but inside the
// login's Planet session.
//
// Threading: every member may be called from any thread. login() blocks (up to verify_timeout);
// call it off the network thread.

#include <atomic>
#include <chrono>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "urs/gateway/hub.hpp"
#include "urs/planet/client.hpp"

namespace urs::gateway {

struct LoginOptions {
  // The space's CAMUS server (host, port, peer name; the token is each login's own), if it has one.
  std::optional<planet::ClientOptions> camus;
  std::string space_token;   // without a CAMUS server: the operators' credential ("" = none can log in)
  std::string viewer_token;  // a credential that sees only ("" = none)
  bool read_only = false;    // every login is a viewer
  std::size_t max_logins = 64;
  std::chrono::seconds idle{12 * 3600};
  std::chrono::milliseconds verify_timeout{3000};
  std::size_t max_failures_per_minute = 20;  // then every login is refused for the rest of the minute
};

struct Login {
  std::string id;       // the session's secret: never logged, never sent to the CAMUS server
  uint64_t number = 0;  // which login of this gateway it is (1, 2, ...): what logs and peer names show
  Role role = Role::viewer;
  std::unique_ptr<planet::Client> client;  // the login's own session with the CAMUS server, if any
  // What the CAMUS server said of the credential (ROLE_UNSPECIFIED and "" without a session).
  planet::Role server_role = planet::ROLE_UNSPECIFIED;
  std::string identity;
};

// The gateway's role for a credential the CAMUS server gives `server_role`: operator only for an
// operator's, and never when `read_only`.
Role role_for(planet::Role server_role, bool read_only);

struct LoginResult {
  std::shared_ptr<const Login> login;  // null on refusal
  int http_status = 200;               // 401 refused, 429 too many failures, 503 server unreachable, ...
  std::string error;
};

class Logins {
 public:
  explicit Logins(LoginOptions options);
  ~Logins();
  Logins(const Logins&) = delete;
  Logins& operator=(const Logins&) = delete;

  LoginResult login(const std::string& credential);
  // The live login with this id (its idle time starts again), or null.
  std::shared_ptr<const Login> find(const std::string& id);
  bool logout(const std::string& id);
  std::size_t size() const;

 private:
  struct Entry {
    std::shared_ptr<const Login> login;
    std::chrono::steady_clock::time_point used;
  };
  void purge(std::chrono::steady_clock::time_point now);  // caller holds mutex_
  bool failed_too_often(std::chrono::steady_clock::time_point now);
  void failed(std::chrono::steady_clock::time_point now);

  const LoginOptions options_;
  mutable std::mutex mutex_;
  std::map<std::string, Entry> logins_;
  std::deque<std::chrono::steady_clock::time_point> failures_;
  std::atomic<uint64_t> numbered_{0};  // logins numbered so far
};

// True if `a` equals `b`, in a time that depends on their lengths only.
bool same_secret(const std::string& a, const std::string& b);
// 32 hex digits from the system's random source.
std::string random_id();

}  // namespace urs::gateway
