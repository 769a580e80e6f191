#include "session_directory.hpp"

#include "urs/util/secret.hpp"

namespace urs::planet::detail {

namespace {
constexpr size_t kSecretBytes = 32;  // 256 bits
}

SessionDirectory::SessionDirectory(std::chrono::milliseconds keep, size_t max_sessions)
    : keep_(keep), max_sessions_(max_sessions) {}

SessionDirectory::Opened SessionDirectory::open(const std::string& secret, const std::string& identity,
                                                const SessionPtr& connection) {
  const std::string presented = secret.empty() ? std::string() : util::sha256_hex(secret);
  std::lock_guard<std::mutex> lock(mutex_);
  purge_locked(Clock::now());
  Opened opened;
  if (!presented.empty()) {
    auto found = by_secret_.find(presented);
    if (found != by_secret_.end()) {
      Entry& entry = sessions_.at(found->second);
      if (entry.identity == identity) {
        if (entry.closed) {
          closed_order_.erase(entry.closed_at);
          entry.closed = false;
        } else {
          opened.previous = entry.connection.lock();
        }
        entry.connection = connection;
        entry.connection_raw = connection.get();
        opened.session = found->second;
        opened.secret = secret;
        opened.resumed = true;
        return opened;
      }
    }
  }
  // A new session: make room by forgetting the longest closed.
  while (sessions_.size() >= max_sessions_ && !closed_order_.empty()) erase_locked(closed_order_.begin()->second);
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

void SessionDirectory::closed(uint64_t session, const Session* connection) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = sessions_.find(session);
  if (it == sessions_.end() || it->second.closed || it->second.connection_raw != connection) return;
  it->second.closed = true;
  it->second.connection.reset();
  it->second.connection_raw = nullptr;
  it->second.closed_at = closed_order_.emplace(Clock::now(), session);
}

void SessionDirectory::forget_identity(const std::string& identity) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto it = sessions_.begin(); it != sessions_.end();) {
    auto next = std::next(it);
    if (it->second.identity == identity) erase_locked(it->first);
    it = next;
  }
}

size_t SessionDirectory::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return sessions_.size();
}

void SessionDirectory::purge_locked(Clock::time_point now) {
  while (!closed_order_.empty() && closed_order_.begin()->first + keep_ <= now) {
    erase_locked(closed_order_.begin()->second);
  }
}

void SessionDirectory::erase_locked(uint64_t session) {
  auto it = sessions_.find(session);
  if (it == sessions_.end()) return;
  if (it->second.closed) closed_order_.erase(it->second.closed_at);
  by_secret_.erase(it->second.secret_hash);
  sessions_.erase(it);
}

}  // namespace urs::planet::detail
