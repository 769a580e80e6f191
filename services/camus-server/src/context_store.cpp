#include "urs/camus_server/context_store.hpp"

#include <spdlog/spdlog.h>

#include "urs/camus_server/agent_util.hpp"
#include "urs/camus_server/topic_pattern.hpp"

namespace urs::camus_server {

namespace gp = google::protobuf;

namespace {

Error not_found(const std::string& key) {
  return make_error(planet::NOT_FOUND, "no context entry " + quote_prefix(key));
}

Error storage_error(const std::string& key, const SqliteError& e) {
  return make_error(planet::INTERNAL, "context entry " + quote_prefix(key) + " not stored: " + e.what());
}

constexpr size_t kMaxOriginBytes = 200;

// Empty if `origin` (ContextSetRequest.source) may be kept as the entry's origin, else why not.
std::string origin_problem(const std::string& origin) {
  if (origin.size() > kMaxOriginBytes) {
    return "it is " + std::to_string(origin.size()) + " bytes long; the limit is " + std::to_string(kMaxOriginBytes);
  }
  for (char c : origin) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return "it holds a control character";
  }
  return {};
}

// The entry that stands for `key` once `source` deleted it at `now` (or it expired): a null value,
// the version after `previous_version`.
camus::ContextEntry tombstone(const std::string& key, const std::string& source, int64_t now,
                              uint64_t previous_version) {
  camus::ContextEntry entry;
  entry.set_key(key);
  entry.mutable_value()->set_null_value(gp::NULL_VALUE);
  entry.set_source(source);
  entry.set_updated_unix_ns(now);
  entry.set_version(previous_version + 1);
  return entry;
}

}  // namespace

ContextStore::ContextStore(const std::string& db_path, agent::EventSink& events, const Clock& clock, Scheduler& timers)
    : events_(events), clock_(clock), timers_(timers), db_(db_path, Durability::Full) {
  db_.exec("CREATE TABLE IF NOT EXISTS context (key TEXT PRIMARY KEY, entry BLOB NOT NULL, deleted INTEGER NOT NULL)");
  Statement load(db_, "SELECT key, entry, deleted FROM context");
  while (load.step()) {
    Row row;
    if (!row.entry.ParseFromString(load.column_blob(1))) {
      throw SqliteError("database '" + db_.path() + "': context entry '" + load.column_text(0) + "' is corrupt");
    }
    row.deleted = load.column_int(2) != 0;
    if (!row.deleted && row.entry.expires_unix_ns() != 0) expiry_.emplace(row.entry.expires_unix_ns(), row.entry.key());
    rows_.emplace(load.column_text(0), std::move(row));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  size_t purged = purge_locked();
  if (purged > 0) spdlog::info("context: {} entries expired while the server was down", purged);
  arm_locked();
}

ContextStore::~ContextStore() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (timer_ != 0) timers_.cancel(timer_);
  timer_ = 0;
}

bool ContextStore::visible_locked(const Row& row, int64_t now) const {
  return !row.deleted && (row.entry.expires_unix_ns() == 0 || row.entry.expires_unix_ns() > now);
}

void ContextStore::write_locked(const Row& row) {
  Statement put(db_, "INSERT OR REPLACE INTO context (key, entry, deleted) VALUES (?, ?, ?)");
  put.bind(1, row.entry.key()).bind_blob(2, row.entry.SerializeAsString()).bind(3, int64_t{row.deleted ? 1 : 0});
  put.step();
}

Result<camus::ContextEntry> ContextStore::get(const std::string& key) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = rows_.find(key);
  if (it == rows_.end() || !visible_locked(it->second, clock_.now_unix_ns())) return not_found(key);
  return it->second.entry;
}

Result<camus::ContextEntry> ContextStore::set(const camus::ContextSetRequest& request, const std::string& caller) {
  const std::string& key = request.key();
  if (auto why = topic_problem(key); !why.empty()) {
    return make_error(planet::BAD_ARGUMENTS, "context key " + quote_prefix(key) + " is not valid: " + why);
  }
  if (auto why = origin_problem(request.source()); !why.empty()) {
    return make_error(planet::BAD_ARGUMENTS, "context entry " + quote_prefix(key) + ": source is not valid: " + why);
  }
  if (!request.has_value() || request.value().kind_case() == gp::Value::KIND_NOT_SET) {
    return make_error(planet::BAD_ARGUMENTS,
                      "context entry " + quote_prefix(key) + ": value is missing (use Delete to remove an entry)");
  }
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t now = clock_.now_unix_ns();
  Row row;
  auto it = rows_.find(key);
  uint64_t version = it == rows_.end() ? 0 : it->second.entry.version();
  row.entry.set_key(key);
  *row.entry.mutable_value() = request.value();
  row.entry.set_source(caller);
  row.entry.set_origin(request.source());
  row.entry.set_updated_unix_ns(now);
  row.entry.set_ttl_ms(request.ttl_ms());
  row.entry.set_expires_unix_ns(request.ttl_ms() == 0 ? 0 : now + int64_t{request.ttl_ms()} * 1'000'000);
  row.entry.set_version(version + 1);
  try {
    write_locked(row);
  } catch (const SqliteError& e) {
    return storage_error(key, e);
  }
  if (it != rows_.end() && it->second.entry.expires_unix_ns() != 0) {
    expiry_.erase({it->second.entry.expires_unix_ns(), key});
  }
  if (row.entry.expires_unix_ns() != 0) expiry_.emplace(row.entry.expires_unix_ns(), key);
  rows_[key] = row;
  events_.publish("context/" + key, row.entry);
  arm_locked();
  return row.entry;
}

Result<Done> ContextStore::remove(const std::string& key, const std::string& caller) {
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t now = clock_.now_unix_ns();
  auto it = rows_.find(key);
  if (it == rows_.end() || !visible_locked(it->second, now)) return not_found(key);
  const Row row{tombstone(key, caller, now, it->second.entry.version()), /*deleted=*/true};
  try {
    write_locked(row);
  } catch (const SqliteError& e) {
    return storage_error(key, e);
  }
  if (it->second.entry.expires_unix_ns() != 0) expiry_.erase({it->second.entry.expires_unix_ns(), key});
  it->second = row;
  events_.publish("context/" + key, row.entry);
  return Done{};
}

Result<std::vector<camus::ContextEntry>> ContextStore::list(const std::string& pattern) const {
  // A glob, like the registry's List; a pattern holding '#' is read as a topic pattern.
  const bool topic = pattern.find('#') != std::string::npos;
  TopicPattern parsed;
  if (topic) {
    auto result = TopicPattern::parse(pattern);
    if (!result.ok()) return result.error();
    parsed = result.value();
  }
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t now = clock_.now_unix_ns();
  std::vector<camus::ContextEntry> out;
  for (const auto& [key, row] : rows_) {
    if (!visible_locked(row, now)) continue;
    if (topic ? !parsed.matches(key) : !(pattern.empty() || glob_match(pattern, key))) continue;
    out.push_back(row.entry);
  }
  return out;
}

size_t ContextStore::purge_expired() {
  std::lock_guard<std::mutex> lock(mutex_);
  size_t purged = purge_locked();
  arm_locked();
  return purged;
}

size_t ContextStore::purge_locked() {
  const int64_t now = clock_.now_unix_ns();
  size_t purged = 0;
  while (!expiry_.empty() && expiry_.begin()->first <= now) {
    std::string key = expiry_.begin()->second;
    auto it = rows_.find(key);
    if (it == rows_.end() || it->second.deleted || it->second.entry.expires_unix_ns() != expiry_.begin()->first) {
      expiry_.erase(expiry_.begin());  // stale index entry
      continue;
    }
    const Row row{tombstone(key, kServerPeerName, now, it->second.entry.version()), /*deleted=*/true};
    try {
      write_locked(row);
    } catch (const SqliteError& e) {
      // Still invisible (expired); the next purge retries.
      spdlog::error("context: purge of expired '{}' failed: {}", key, e.what());
      break;
    }
    expiry_.erase(expiry_.begin());
    it->second = row;
    events_.publish("context/" + key, row.entry);
    ++purged;
  }
  return purged;
}

void ContextStore::arm_locked() {
  if (expiry_.empty()) return;
  const int64_t due = expiry_.begin()->first;
  if (timer_ != 0 && timer_due_ns_ <= due) return;  // an earlier (or equal) purge is already armed
  if (timer_ != 0) timers_.cancel(timer_);
  const int64_t now = clock_.now_unix_ns();
  int64_t delay_ns = due > now ? due - now : 0;
  auto delay = std::chrono::milliseconds((delay_ns + 999'999) / 1'000'000);
  timer_due_ns_ = due;
  timer_ = timers_.schedule_after(delay, [this] {
    std::lock_guard<std::mutex> lock(mutex_);
    timer_ = 0;
    purge_locked();
    arm_locked();
  });
}

const gp::ServiceDescriptor& ContextAgent::interface() const {
  return *camus::ContextEntry::descriptor()->file()->FindServiceByName("Context");
}

agent::Outcome ContextAgent::invoke(const gp::MethodDescriptor& method, const gp::Message& request, gp::Message& reply,
                                    const agent::CallContext& ctx) {
  const std::string& op = method.name();
  if (op == "Get") {
    camus::ContextGetRequest storage;
    auto entry = store_.get(message_as(request, storage).key());
    if (!entry.ok()) return refused(entry);
    fill_reply(reply, entry.value());
    return agent::Outcome::ok();
  }
  if (op == "Set") {
    camus::ContextSetRequest storage;
    auto entry = store_.set(message_as(request, storage), ctx.caller.name);
    if (!entry.ok()) return refused(entry);
    fill_reply(reply, entry.value());
    return agent::Outcome::ok();
  }
  if (op == "Delete") {
    camus::ContextDeleteRequest storage;
    auto done = store_.remove(message_as(request, storage).key(), ctx.caller.name);
    if (!done.ok()) return refused(done);
    return agent::Outcome::ok();
  }
  if (op == "List") {
    camus::ContextListRequest storage;
    auto entries = store_.list(message_as(request, storage).pattern());
    if (!entries.ok()) return refused(entries);
    camus::ContextListReply out;
    for (auto& entry : entries.value()) *out.add_entries() = std::move(entry);
    fill_reply(reply, out);
    return agent::Outcome::ok();
  }
  return agent::Outcome::error(call::Status::UNKNOWN_OPERATION,
                               "interface urs.camus.Context has no operation '" + op + "'");
}

}  // namespace urs::camus_server
