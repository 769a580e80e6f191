#pragma once
// The server's resumable sessions. Each has a number (Identity::session) and a secret the server
// issues in Welcome; a later Hello that presents the secret with the same credential continues
// the session (same number), so what hangs on it (service registrations, publish
// de-duplication) carries over a reconnect, and nothing the client chose can take it over.
//
// Secrets are kept only as their SHA-256. A session whose connection closed stays resumable for
// `keep`, within fair shares of the closed sessions kept (FairQueue): a credential over its share
// loses its own oldest, and when all together are too many the credential holding the most loses
// its oldest; so connection churn by one credential never makes another's session unresumable.
// Open sessions are bounded by the server's connection limits.
//
// A session forgotten while its client may come back (evicted, or closed longer than `keep`)
// leaves a tombstone: its secret's hash, credential, number and the highest publish_id it
// received, within the same fair shares. A Hello presenting it gets a new session that knows
// those publish ids were received before (Opened::evicted_*), so a resend is refused instead of
// delivered twice.
//
// Thread-safe; never blocks on I/O.

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "urs/planet/fair_share.hpp"
#include "urs/planet/server.hpp"

namespace urs::planet::detail {

class SessionDirectory {
 public:
  using Clock = std::chrono::steady_clock;

  // `retained` bounds the closed sessions kept resumable (and, as many again, the tombstones).
  SessionDirectory(std::chrono::milliseconds keep, FairShare::Limits retained);

  struct Opened {
    uint64_t session = 0;
    std::string secret;  // to put in Welcome; the caller never logs it
    bool resumed = false;
    SessionPtr previous;  // the session's connection still open, to be closed by the caller
    // The Hello presented the secret of a session this server forgot (evicted, or closed too
    // long): its number, and the highest publish_id it had received (0: none).
    uint64_t forgotten_session = 0;
    uint64_t forgotten_publish_through = 0;
  };
  // The session `secret` names, if it is remembered and belongs to `identity`; a new one
  // otherwise. `connection` becomes the session's connection.
  Opened open(const std::string& secret, const ShareHolder& identity, const SessionPtr& connection);
  // `connection` of `session` closed, having received publish ids up to `publish_through`; the
  // session becomes resumable (unless another connection has taken it over meanwhile).
  void closed(uint64_t session, const Session* connection, uint64_t publish_through);
  // Forgets every session of `identity` (its credential was revoked or changed), tombstones
  // included.
  void forget_identity(const std::string& identity);

  size_t size() const;      // sessions remembered, open ones included
  size_t retained() const;  // of them, closed ones
  size_t tombstones() const;

 private:
  struct Entry {
    ShareHolder identity;
    std::string secret_hash;
    std::weak_ptr<Session> connection;
    const Session* connection_raw = nullptr;  // to compare without locking the weak pointer
    Clock::time_point closed_at;
    bool closed = false;
    uint64_t publish_through = 0;
  };
  struct Tombstone {
    std::string identity;
    std::string secret_hash;
    uint64_t session = 0;
    uint64_t publish_through = 0;
  };
  void purge_locked(Clock::time_point now);
  // Forgets `session`; with `tombstone`, leaves one behind.
  void erase_locked(uint64_t session, bool tombstone);
  void bury_locked(const Entry& entry, uint64_t session);

  const std::chrono::milliseconds keep_;
  mutable std::mutex mutex_;
  uint64_t next_session_ = 1;
  std::unordered_map<uint64_t, Entry> sessions_;
  std::unordered_map<std::string, uint64_t> by_secret_;  // SHA-256 of the secret -> session
  FairQueue closed_;                                     // closed sessions, by closing time
  uint64_t next_tombstone_ = 1;
  std::unordered_map<uint64_t, Tombstone> tombstones_;
  std::unordered_map<std::string, uint64_t> tombstone_by_secret_;
  FairQueue buried_;  // tombstones, oldest first
};

}  // namespace urs::planet::detail
