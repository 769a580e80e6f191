#pragma once
// The context manager: typed key/value entries (google.protobuf.Value) with source (who set it, as
// authenticated), origin (what the setter declared), time, TTL and a per-key version.
//
//  - Keys follow the topic rules ("robot1/pose": non-empty levels, no wildcards); a change of key K
//    publishes "context/K" carrying the ContextEntry (content type "urs.camus.ContextEntry").
//  - A change is committed to SQLite (WAL, synchronous=FULL) before the call returns, so an
//    answered Set/Delete survives a crash.
//  - Expired entries are invisible at once and purged by a timer; the purge publishes the change
//    with a null value. Deletion does the same.
//  - The version of a key increases with every change, also across deletions and restarts
//    (deleted keys keep a tombstone).
//
// Threading: thread-safe; Set/Delete wait for the disk (run them off the I/O thread).

#include <map>
#include <mutex>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "camus.pb.h"
#include "urs/agent/agent.hpp"
#include "urs/camus_server/clock.hpp"
#include "urs/camus_server/names.hpp"
#include "urs/camus_server/result.hpp"
#include "urs/camus_server/sqlite.hpp"
#include "urs/camus_server/timer.hpp"

namespace urs::camus_server {

// Read access to the context (task manager's wait_context).
class ContextReader {
 public:
  virtual ~ContextReader() = default;
  // NOT_FOUND "no context entry 'k'" if absent, deleted or expired.
  virtual Result<camus::ContextEntry> get(const std::string& key) const = 0;
};

class ContextStore final : public ContextReader {
 public:
  // Opens or creates `db_path` ("" = in memory), purges what expired while the server was down
  // and arms the purge timer. Throws SqliteError. `events`, `clock` and `timers` must outlive it.
  ContextStore(const std::string& db_path, agent::EventSink& events, const Clock& clock, Scheduler& timers);
  ~ContextStore() override;
  ContextStore(const ContextStore&) = delete;
  ContextStore& operator=(const ContextStore&) = delete;

  Result<camus::ContextEntry> get(const std::string& key) const override;
  // `caller` (the caller's authenticated identity) becomes the entry's source; the request's own
  // `source` is kept as its origin (display only; at most 200 bytes, no control characters).
  Result<camus::ContextEntry> set(const camus::ContextSetRequest& request, const std::string& caller);
  Result<Done> remove(const std::string& key, const std::string& caller);
  // Keys matching a glob ("robot1/*": '*' any run of characters, '?' one); empty = all. A pattern
  // holding '#' is a topic pattern instead ("robot1/#"). Sorted by key.
  Result<std::vector<camus::ContextEntry>> list(const std::string& pattern) const;
  // Removes every expired entry (publishing each change); returns how many.
  size_t purge_expired();

 private:
  struct Row {
    camus::ContextEntry entry;
    bool deleted = false;
  };
  bool visible_locked(const Row& row, int64_t now) const;
  void write_locked(const Row& row);  // throws SqliteError
  void arm_locked();
  size_t purge_locked();

  agent::EventSink& events_;
  const Clock& clock_;
  Scheduler& timers_;
  mutable std::mutex mutex_;
  mutable Database db_;
  std::map<std::string, Row> rows_;
  std::set<std::pair<int64_t, std::string>> expiry_;  // (expires_unix_ns, key) of live TTL entries
  Scheduler::TimerId timer_ = 0;
  int64_t timer_due_ns_ = 0;
};

// The built-in service "camus.context" (urs.camus.Context) for the service container.
class ContextAgent final : public agent::ServiceAgent {
 public:
  static constexpr const char* kName = "camus.context";
  explicit ContextAgent(ContextStore& store) : store_(store) {}
  const google::protobuf::ServiceDescriptor& interface() const override;
  agent::Outcome invoke(const google::protobuf::MethodDescriptor& method, const google::protobuf::Message& request,
                        google::protobuf::Message& reply, const agent::CallContext& ctx) override;

 private:
  ContextStore& store_;
};

}  // namespace urs::camus_server
