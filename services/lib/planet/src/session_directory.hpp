#pragma once
// The server's resumable sessions. Each has a number (Identity::session) and a secret the server
// issues in Welcome; a later Hello that presents the secret with the same credential continues
// the session (same number), so what hangs on it (service registrations, publish
// de-duplication) carries over a reconnect, and nothing the client chose can take it over.
//
// Secrets are kept only as their SHA-256. A session whose connection closed stays resumable for
// `keep`; at most `max_sessions` are remembered (the longest closed are forgotten first; open ones
// are bounded by the server's connection limits).
//
// Thread-safe; never blocks on I/O.

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "urs/planet/server.hpp"

namespace urs::planet::detail {

class SessionDirectory {
 public:
  using Clock = std::chrono::steady_clock;

  SessionDirectory(std::chrono::milliseconds keep, size_t max_sessions);

  struct Opened {
    uint64_t session = 0;
    std::string secret;  // to put in Welcome; the caller never logs it
    bool resumed = false;
    SessionPtr previous;  // the session's connection still open, to be closed by the caller
  };
  // The session `secret` names, if it is remembered and belongs to `identity`; a new one
  // otherwise. `connection` becomes the session's connection.
  Opened open(const std::string& secret, const std::string& identity, const SessionPtr& connection);
  // `connection` of `session` closed; the session becomes resumable (unless another connection
  // has taken it over meanwhile).
  void closed(uint64_t session, const Session* connection);
  // Forgets every session of `identity` (its credential was revoked or changed).
  void forget_identity(const std::string& identity);

  size_t size() const;

 private:
  struct Entry {
    std::string identity;
    std::string secret_hash;
    std::weak_ptr<Session> connection;
    const Session* connection_raw = nullptr;  // to compare without locking the weak pointer
    std::multimap<Clock::time_point, uint64_t>::iterator closed_at;
    bool closed = false;
  };
  void purge_locked(Clock::time_point now);
  void erase_locked(uint64_t session);

  const std::chrono::milliseconds keep_;
  const size_t max_sessions_;
  mutable std::mutex mutex_;
  uint64_t next_session_ = 1;
  std::unordered_map<uint64_t, Entry> sessions_;
  std::unordered_map<std::string, uint64_t> by_secret_;       // SHA-256 of the secret -> session
  std::multimap<Clock::time_point, uint64_t> closed_order_;   // closed sessions by closing time
};

}  // namespace urs::planet::detail
