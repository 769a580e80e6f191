#include "session_directory.hpp"

#include "urs/util/secret.hpp"

namespace urs::planet::detail {

namespace {
constexpr size_t kSecretBytes = 32;  // 256 bits
}

SessionDirectory::SessionDirectory(std::chrono::milliseconds keep, FairShare::Limits retained)
    : keep_(keep), closed_(retained), buried_(retained) {}

SessionDirectory::Opened SessionDirectory::open(const std::string& secret, const ShareHolder& identity,
                                                const SessionPtr& connection) {
  const std::string presented = secret.empty() ? std::string() : util::sha256_hex(secret);
  std::lock_guard<std::mutex> lock(mutex_);
  purge_locked(Clock::now());
  Opened opened;
  if (!presented.empty()) {
    auto found = by_secret_.find(presented);
    if (found != by_secret_.end()) {
      Entry& entry = sessions_.at(found->second);
      if (entry.identity.credential == identity.credential) {
        if (entry.closed) {
          closed_.remove(found->second);
          entry.closed = false;
        } else {
          opened.previous = entry.connection.lock();
        }
        entry.identity = identity;
        entry.connection = connection;
        entry.connection_raw = connection.get();
        opened.session = found->second;
        opened.secret = secret;
        opened.resumed = true;
        return opened;
      }
    }
    auto buried = tombstone_by_secret_.find(presented);
    if (buried != tombstone_by_secret_.end()) {
      const Tombstone& tombstone = tombstones_.at(buried->second);
      if (tombstone.identity == identity.credential) {
        opened.forgotten_session = tombstone.session;
        opened.forgotten_publish_through = tombstone.publish_through;
        buried_.remove(buried->second);
        tombstones_.erase(buried->second);
        tombstone_by_secret_.erase(buried);
      }
    }
  }
  opened.session = next_session_++;
  opened.secret = util::random_secret_hex(kSecretBytes);
  Entry entry;
  entry.identity = identity;
  entry.secret_hash = util::sha256_hex(opened.secret);
  entry.connection = connection;
  entry.connection_raw = connection.get();
  by_secret_.emplace(entry.secret_hash, opened.session);
  sessions_.emplace(opened.session, std::move(entry));
  return opened;
}

void SessionDirectory::closed(uint64_t session, const Session* connection, uint64_t publish_through) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = sessions_.find(session);
  if (it == sessions_.end()) return;
  Entry& entry = it->second;
  // A connection the session was resumed from may close later: what it received still counts.
  entry.publish_through = std::max(entry.publish_through, publish_through);
  if (entry.closed || entry.connection_raw != connection) return;
  entry.closed = true;
  entry.connection.reset();
  entry.connection_raw = nullptr;
  entry.closed_at = Clock::now();
  for (uint64_t evicted : closed_.add(session, entry.identity)) erase_locked(evicted, /*tombstone=*/true);
}

void SessionDirectory::forget_identity(const std::string& identity) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto it = sessions_.begin(); it != sessions_.end();) {
    auto next = std::next(it);
    if (it->second.identity.credential == identity) erase_locked(it->first, /*tombstone=*/false);
    it = next;
  }
  for (auto it = tombstones_.begin(); it != tombstones_.end();) {
    if (it->second.identity == identity) {
      buried_.remove(it->first);
      tombstone_by_secret_.erase(it->second.secret_hash);
      it = tombstones_.erase(it);
    } else {
      ++it;
    }
  }
}

size_t SessionDirectory::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return sessions_.size();
}

size_t SessionDirectory::retained() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_.size();
}

size_t SessionDirectory::tombstones() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return tombstones_.size();
}

void SessionDirectory::purge_locked(Clock::time_point now) {
  for (auto oldest = closed_.oldest(); oldest; oldest = closed_.oldest()) {
    if (sessions_.at(*oldest).closed_at + keep_ > now) break;
    erase_locked(*oldest, /*tombstone=*/true);
  }
}

void SessionDirectory::erase_locked(uint64_t session, bool tombstone) {
  auto it = sessions_.find(session);
  if (it == sessions_.end()) return;
  closed_.remove(session);
  if (tombstone) bury_locked(it->second, session);
  by_secret_.erase(it->second.secret_hash);
  sessions_.erase(it);
}

void SessionDirectory::bury_locked(const Entry& entry, uint64_t session) {
  const uint64_t id = next_tombstone_++;
  tombstones_.emplace(id, Tombstone{entry.identity.credential, entry.secret_hash, session, entry.publish_through});
  tombstone_by_secret_.emplace(entry.secret_hash, id);
  for (uint64_t evicted : buried_.add(id, entry.identity)) {
    auto gone = tombstones_.find(evicted);
    tombstone_by_secret_.erase(gone->second.secret_hash);
    tombstones_.erase(gone);
  }
}

}  // namespace urs::planet::detail
