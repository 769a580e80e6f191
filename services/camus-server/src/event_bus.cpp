#include "urs/camus_server/event_bus.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <utility>

#include "urs/util/trace.hpp"

namespace urs::camus_server {

namespace {
constexpr uint64_t kInternalOwnerBit = 1ull << 63;
constexpr uint64_t kConnectionBudgetBit = 1ull << 62;  // subscribes count per connection, publishes per session

uint64_t reserved(size_t total, unsigned percent) { return uint64_t{total} * percent / 100; }

planet::FairShare::Limits limits(size_t total, const char* total_name, size_t per_credential,
                                 const char* per_credential_name, unsigned percent, const char* what) {
  return planet::FairShare::Limits{total,      per_credential,      reserved(total, percent),
                                   total_name, per_credential_name, "reserved_percent " + std::to_string(percent),
                                   what};
}
}  // namespace

struct EventBus::Job {
  enum class Kind { Publish, Subscribe, Unsubscribe, DropOwner, Flush };
  Kind kind = Kind::Flush;
  size_t bytes = 0;            // counted against event_queue_bytes (with `counted`)
  bool counted = false;        // an operation of a peer, counted against event_queue
  planet::ShareHolder holder;  // whose share of event_queue it uses
  uint64_t budget = 0;         // whose share of event_queue_per_session it uses (0: none)
  // Publish
  PublishInput input;
  PublishAckFn publish_ack;
  // Subscribe / Unsubscribe / DropOwner
  uint64_t owner = 0;
  uint64_t subscription_id = 0;
  uint64_t resume_after = 0;
  TopicPattern pattern;
  bool internal = false;  // the server's own subscription: replays from 0, not counted
  DeliverFn deliver;
  SubscribeAckFn subscribe_ack;
};

EventBus::EventBus(const std::string& db_path, EventBusOptions options, const Clock& clock)
    : options_(options),
      clock_(clock),
      db_(db_path, Durability::Normal),
      queued_(limits(options.event_queue, "event_queue", options.event_queue_per_credential,
                     "event_queue_per_credential", options.reserved_percent, "operations queued")),
      queued_bytes_(limits(options.event_queue_bytes, "event_queue_bytes", options.event_queue_bytes_per_credential,
                           "event_queue_bytes_per_credential", options.reserved_percent, "bytes queued")),
      peer_subscriptions_(limits(options.max_subscriptions, "max_subscriptions",
                                 options.max_subscriptions_per_credential, "max_subscriptions_per_credential",
                                 options.reserved_percent, "subscriptions")),
      publisher_order_(limits(options.max_publishers, "max_publishers", options.max_publishers_per_credential,
                              "max_publishers_per_credential", options.reserved_percent, "publishing sessions")) {
  if (options_.retention == 0) options_.retention = 1;
  db_.exec(
      "CREATE TABLE IF NOT EXISTS events (seq INTEGER PRIMARY KEY, topic TEXT NOT NULL, payload BLOB, "
      "content_type TEXT, source TEXT, time_ns INTEGER);"
      "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value INTEGER);");
  {
    // A log written before events carried their trace gets the column (empty for its events).
    bool has_trace = false;
    Statement columns(db_, "SELECT name FROM pragma_table_info('events')");
    while (columns.step()) has_trace = has_trace || columns.column_text(0) == "traceparent";
    if (!has_trace) db_.exec("ALTER TABLE events ADD COLUMN traceparent TEXT");
  }
  uint64_t last = 0;
  {
    Statement max_seq(db_, "SELECT COALESCE(MAX(seq), 0), COALESCE(MIN(seq), 0) FROM events");
    if (max_seq.step()) {
      last = static_cast<uint64_t>(max_seq.column_int(0));
      uint64_t oldest = static_cast<uint64_t>(max_seq.column_int(1));
      oldest_seq_ = oldest;
    }
    Statement stored(db_, "SELECT value FROM meta WHERE key = 'last_seq'");
    if (stored.step()) last = std::max(last, static_cast<uint64_t>(stored.column_int(0)));
  }
  last_seq_ = last;
  if (oldest_seq_.load() == 0) oldest_seq_ = last + 1;
  if (last > 0) spdlog::info("event log '{}': continuing after seq {}", db_.path(), last);
  thread_ = std::thread([this] { run(); });
}

EventBus::~EventBus() { stop(); }

void EventBus::refuse(Job& job, planet::Status status, const std::string& why) {
  if (job.kind == Job::Kind::Publish && job.publish_ack) {
    planet::PublishAck ack;
    ack.set_publish_id(job.input.publish_id);
    ack.set_status(status);
    ack.set_message("event on " + quote_prefix(job.input.topic) + " not accepted: " + why);
    job.publish_ack(ack);
  } else if (job.kind == Job::Kind::Subscribe && job.subscribe_ack) {
    planet::SubscribeAck ack;
    ack.set_subscription_id(job.subscription_id);
    ack.set_status(status);
    ack.set_message("subscription to " + quote_prefix(job.pattern.text()) + " not accepted: " + why);
    job.subscribe_ack(ack);
  }
}

bool EventBus::enqueue(Job job) {
  std::unique_lock<std::mutex> lock(mutex_);
  planet::Status status = planet::OK;
  std::string why;
  const bool per_session = job.counted && job.budget != 0;
  if (stopping_) {
    status = planet::UNAVAILABLE;
    why = "server is shutting down";
  } else if (per_session && queued_by_session_[job.budget] >= options_.event_queue_per_session) {
    refusals_.count("event_queue_per_session");
    status = planet::RESOURCE_EXHAUSTED;
    why = "the event bus is behind: this session has " + std::to_string(queued_by_session_[job.budget]) +
          " operations queued (event_queue_per_session " + std::to_string(options_.event_queue_per_session) +
          "); retry later";
  } else if (job.counted) {
    if (auto refusal = queued_.take(job.holder, 1); !refusal.empty()) {
      status = planet::RESOURCE_EXHAUSTED;
      why = "the event bus is behind: " + refusal;
    } else if (refusal = queued_bytes_.take(job.holder, job.bytes); !refusal.empty()) {
      queued_.give(job.holder, 1);
      status = planet::RESOURCE_EXHAUSTED;
      why = "the event bus is behind: " + refusal;
    }
  }
  if (status == planet::OK) {
    if (per_session) ++queued_by_session_[job.budget];
    queue_.push_back(std::move(job));
    ++enqueued_;
    wake_.notify_one();
    return true;
  }
  if (per_session && queued_by_session_[job.budget] == 0) queued_by_session_.erase(job.budget);
  lock.unlock();
  refuse(job, status, why);
  return false;
}

bool EventBus::publish(PublishInput input, PublishAckFn ack) {
  // Only the server's own events (source kServerPeerName: no credential may take the name, no
  // task owner has it) go on server topics, uncounted; everyone else follows the peers' rules.
  const bool server = input.source == kServerPeerName;
  Job job;
  job.kind = Job::Kind::Publish;
  job.bytes = input.topic.size() + input.payload.size() + input.content_type.size();
  job.counted = !server;
  job.holder = planet::ShareHolder{input.source, input.privileged};
  job.budget = input.publisher;
  job.input = std::move(input);
  job.publish_ack = std::move(ack);
  const PublishInput& in = job.input;
  if (in.publisher != 0 && in.publish_id == 0) {
    refuse(job, planet::BAD_ARGUMENTS, "publish_id 0 is not valid: number the publishes of a session from 1");
    return false;
  }
  // The server's own topics are bounded by what it validates itself (service names, context keys).
  const TopicLimits unbounded{SIZE_MAX, SIZE_MAX};
  if (auto why = topic_problem(in.topic, server ? unbounded : options_.topics); !why.empty()) {
    refuse(job, planet::BAD_ARGUMENTS, "the topic is not valid: " + why);
    return false;
  }
  if (!server && is_server_topic(in.topic)) {
    refuse(job, planet::PERMISSION_DENIED,
           "topics under '" + in.topic.substr(0, in.topic.find('/')) +
               "/' are published by the server alone (registry/, context/ and task/ are server topics)");
    return false;
  }
  return enqueue(std::move(job));
}

void EventBus::subscribe(uint64_t owner, const planet::Subscribe& request, DeliverFn deliver, SubscribeAckFn ack,
                         const planet::ShareHolder& subscriber) {
  Job job;
  job.kind = Job::Kind::Subscribe;
  job.counted = true;
  job.bytes = request.pattern().size();
  job.holder = subscriber;
  if (job.holder.credential.empty()) job.holder.credential = "session " + std::to_string(owner);
  job.budget = owner | kConnectionBudgetBit;
  job.owner = owner;
  job.subscription_id = request.subscription_id();
  job.resume_after = request.resume_after_seq();
  job.deliver = std::move(deliver);
  job.subscribe_ack = std::move(ack);
  auto parsed = TopicPattern::parse(request.pattern(), options_.topics);
  if (!parsed.ok()) {
    if (job.subscribe_ack) {
      planet::SubscribeAck refused;
      refused.set_subscription_id(job.subscription_id);
      refused.set_status(parsed.status());
      refused.set_message(parsed.message());
      job.subscribe_ack(refused);
    }
    return;
  }
  job.pattern = std::move(parsed.value());
  enqueue(std::move(job));
}

uint64_t EventBus::subscribe_internal(const TopicPattern& pattern, uint64_t resume_after_seq, DeliverFn deliver) {
  uint64_t owner = kInternalOwnerBit | ++next_internal_;
  Job job;
  job.kind = Job::Kind::Subscribe;
  job.owner = owner;
  job.subscription_id = owner;
  job.resume_after = resume_after_seq;
  job.pattern = pattern;
  job.internal = true;
  job.deliver = std::move(deliver);
  enqueue(std::move(job));
  return owner;
}

void EventBus::unsubscribe_internal(uint64_t handle) { drop_owner(handle); }

void EventBus::unsubscribe(uint64_t owner, uint64_t subscription_id) {
  Job job;
  job.kind = Job::Kind::Unsubscribe;
  job.owner = owner;
  job.subscription_id = subscription_id;
  enqueue(std::move(job));
}

void EventBus::drop_owner(uint64_t owner) {
  Job job;
  job.kind = Job::Kind::DropOwner;
  job.owner = owner;
  enqueue(std::move(job));
}

void EventBus::flush() {
  std::unique_lock<std::mutex> lock(mutex_);
  uint64_t target = enqueued_;
  idle_.wait(lock, [&] { return done_ >= target || stopped_; });
}

void EventBus::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    wake_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
  std::lock_guard<std::mutex> lock(mutex_);
  stopped_ = true;
  idle_.notify_all();
}

uint64_t EventBus::oldest_retained_seq() const { return oldest_seq_.load(); }

size_t EventBus::subscriptions() const { return subscription_count_.load(); }

void EventBus::run() {
  for (;;) {
    std::vector<Job> jobs;  // a run of publishes (at most `batch`), or one other operation
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping and drained
      do {
        jobs.push_back(std::move(queue_.front()));
        queue_.pop_front();
      } while (jobs.back().kind == Job::Kind::Publish && jobs.size() < options_.batch && !queue_.empty() &&
               queue_.front().kind == Job::Kind::Publish);
    }
    Job& first = jobs.front();
    switch (first.kind) {
      case Job::Kind::Publish:
        process_publishes(jobs);
        break;
      case Job::Kind::Subscribe:
        process_subscribe(first);
        break;
      case Job::Kind::Unsubscribe: {
        auto it = subscriptions_.find({first.owner, first.subscription_id});
        if (it != subscriptions_.end()) remove_subscription(it);
        break;
      }
      case Job::Kind::DropOwner:
        for (auto it = subscriptions_.lower_bound({first.owner, 0});
             it != subscriptions_.end() && it->first.first == first.owner;) {
          auto next = std::next(it);
          remove_subscription(it);
          it = next;
        }
        break;
      case Job::Kind::Flush:
        break;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& job : jobs) {
      if (!job.counted) continue;
      queued_.give(job.holder, 1);
      queued_bytes_.give(job.holder, job.bytes);
      if (job.budget == 0) continue;
      auto share = queued_by_session_.find(job.budget);
      if (share != queued_by_session_.end() && --share->second == 0) queued_by_session_.erase(share);
    }
    done_ += jobs.size();
    idle_.notify_all();
  }
}

void EventBus::remember_id(const PublishInput& input, uint64_t seq) {
  const uint64_t publisher = input.publisher;
  const uint64_t publish_id = input.publish_id;
  auto [it, added] = publishers_.try_emplace(publisher);
  PublisherIds& ids = it->second;
  // Ids arrive increasing; one below `last` fills a gap (an id never accepted before).
  auto at = std::lower_bound(ids.recent.begin(), ids.recent.end(), std::make_pair(publish_id, uint64_t{0}));
  ids.recent.insert(at, {publish_id, seq});
  ids.last = std::max(ids.last, publish_id);
  while (ids.recent.size() > options_.dedupe_window) ids.recent.pop_front();
  if (!added) {
    publisher_order_.touch(publisher);
    return;
  }
  // A new publishing session: one over its credential's share pushes out that credential's
  // least recent; too many together push out the heaviest credential's.
  for (uint64_t forgotten : publisher_order_.add(publisher, planet::ShareHolder{input.source, input.privileged})) {
    publishers_.erase(forgotten);
  }
}

void EventBus::forget_id(uint64_t publisher, uint64_t publish_id) {
  auto it = publishers_.find(publisher);
  if (it == publishers_.end()) return;
  auto& recent = it->second.recent;
  auto at = std::lower_bound(recent.begin(), recent.end(), std::make_pair(publish_id, uint64_t{0}));
  if (at != recent.end() && at->first == publish_id) recent.erase(at);
  it->second.last = recent.empty() ? 0 : std::max_element(recent.begin(), recent.end())->first;
}

void EventBus::process_publishes(std::vector<Job>& batch) {
  struct Outcome {
    planet::PublishAck ack;
    bool deliver = false;
    planet::Event event;
  };
  std::vector<Outcome> outcomes(batch.size());
  std::vector<std::pair<uint64_t, uint64_t>> new_ids;  // (publisher, publish id) remembered by this batch
  uint64_t seq = last_seq_.load();
  const int64_t now = clock_.now_unix_ns();
  std::string failure;
  try {
    Transaction tx(db_);
    Statement insert(db_,
                     "INSERT INTO events (seq, topic, payload, content_type, source, time_ns, traceparent) "
                     "VALUES (?, ?, ?, ?, ?, ?, ?)");
    for (size_t i = 0; i < batch.size(); ++i) {
      PublishInput& in = batch[i].input;
      Outcome& out = outcomes[i];
      out.ack.set_publish_id(in.publish_id);
      const bool dedupe = in.publisher != 0;
      if (dedupe) {
        auto known = publishers_.find(in.publisher);
        if (known != publishers_.end() && in.publish_id <= known->second.last) {
          const auto& recent = known->second.recent;
          auto at = std::lower_bound(recent.begin(), recent.end(), std::make_pair(in.publish_id, uint64_t{0}));
          if (at != recent.end() && at->first == in.publish_id) {
            out.ack.set_seq(at->second);  // a resent duplicate: same seq, not delivered again
            continue;
          }
          if (recent.empty() || in.publish_id < recent.front().first) {
            out.ack.set_status(planet::ALREADY_EXISTS);
            out.ack.set_message("publish_id " + std::to_string(in.publish_id) +
                                " is older than the de-duplication window (the newest " +
                                std::to_string(options_.dedupe_window) +
                                " ids of this session); it was accepted or refused before and is not delivered again");
            continue;
          }
        }
      }
      ++seq;
      insert.bind(1, static_cast<int64_t>(seq))
          .bind(2, in.topic)
          .bind_blob(3, in.payload)
          .bind(4, in.content_type)
          .bind(5, in.source)
          .bind(6, now)
          .bind(7, in.traceparent);
      insert.step();
      insert.reset();
      out.ack.set_seq(seq);
      out.deliver = true;
      if (dedupe) {
        remember_id(in, seq);
        new_ids.emplace_back(in.publisher, in.publish_id);
      }
      out.event.set_seq(seq);
      out.event.set_topic(std::move(in.topic));
      out.event.set_payload(std::move(in.payload));
      out.event.set_content_type(std::move(in.content_type));
      out.event.set_source(std::move(in.source));
      out.event.set_time_unix_ns(now);
      out.event.set_traceparent(std::move(in.traceparent));
    }
    if (seq != last_seq_.load()) {
      Statement meta(db_, "INSERT OR REPLACE INTO meta (key, value) VALUES ('last_seq', ?)");
      meta.bind(1, static_cast<int64_t>(seq)).step();
      if (seq > options_.retention) {
        Statement trim(db_, "DELETE FROM events WHERE seq <= ?");
        trim.bind(1, static_cast<int64_t>(seq - options_.retention)).step();
      }
    }
    tx.commit();
  } catch (const SqliteError& e) {
    failure = e.what();
  }

  if (!failure.empty()) {
    spdlog::error("event log write failed: {}", failure);
    for (auto& [publisher, id] : new_ids) forget_id(publisher, id);
    for (size_t i = 0; i < batch.size(); ++i) {
      Outcome& out = outcomes[i];
      if (out.deliver) {
        out.deliver = false;
        out.ack.set_seq(0);
        out.ack.set_status(planet::INTERNAL);
        out.ack.set_message("event on " + quote_prefix(out.event.topic()) + " not stored: " + failure);
      }
    }
  } else if (seq > last_seq_.load()) {
    if (oldest_seq_.load() > seq) oldest_seq_ = last_seq_.load() + 1;  // log was empty
    if (seq > options_.retention) oldest_seq_ = std::max(oldest_seq_.load(), seq - options_.retention + 1);
    published_ += seq - last_seq_.load();
    last_seq_ = seq;
  }

  // Each event reaches its subscribers before its publisher hears it was accepted.
  for (size_t i = 0; i < batch.size(); ++i) {
    if (outcomes[i].deliver) deliver_live(outcomes[i].event);
    if (batch[i].publish_ack) batch[i].publish_ack(outcomes[i].ack);
  }
}

void EventBus::remove_subscription(std::map<SubKey, Subscription>::iterator it) {
  const uint64_t owner = it->first.first;
  index_.erase(it->second.pattern, it->first);
  if ((owner & kInternalOwnerBit) == 0) {
    peer_subscriptions_.give(it->second.subscriber, 1);
    auto count = per_owner_.find(owner);
    if (count != per_owner_.end() && --count->second == 0) per_owner_.erase(count);
  }
  subscriptions_.erase(it);
  subscription_count_ = subscriptions_.size();
}

void EventBus::deliver_live(const planet::Event& event) {
  std::vector<SubKey> hits;
  index_.match(event.topic(), hits);
  std::sort(hits.begin(), hits.end());  // a stable order across subscriptions
  for (const SubKey& key : hits) {
    auto it = subscriptions_.find(key);
    if (it == subscriptions_.end()) continue;
    planet::Event copy = event;
    copy.set_subscription_id(key.second);
    if (!hand(it->second.deliver, copy)) remove_subscription(it);
  }
}

bool EventBus::hand(const DeliverFn& deliver, const planet::Event& event) {
  if (deliver(event)) {
    delivered_.fetch_add(1, std::memory_order_relaxed);
    return true;
  }
  dropped_.fetch_add(1, std::memory_order_relaxed);
  return false;
}

EventBusStats EventBus::stats() const {
  EventBusStats stats;
  stats.published = published_.load();
  stats.delivered = delivered_.load();
  stats.dropped = dropped_.load();
  stats.queued_bytes = queued_bytes_.used();
  stats.subscriptions = subscription_count_.load();
  planet::Refusals all;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats.queued = queue_.size();
    for (const auto& [limit, count] : refusals_.snapshot()) all.count(limit, count);
  }
  for (const auto* share : {&queued_, &queued_bytes_, &peer_subscriptions_}) {
    for (const auto& [limit, count] : share->refusals()) all.count(limit, count);
  }
  stats.refusals = all.snapshot();
  return stats;
}

void EventBus::process_subscribe(Job& job) {
  planet::SubscribeAck ack;
  ack.set_subscription_id(job.subscription_id);
  auto send_ack = [&] {
    if (job.subscribe_ack) job.subscribe_ack(ack);
  };
  SubKey key{job.owner, job.subscription_id};
  if (subscriptions_.count(key) != 0) {
    ack.set_status(planet::ALREADY_EXISTS);
    ack.set_message("subscription " + std::to_string(job.subscription_id) + " already exists on this session");
    send_ack();
    return;
  }
  if (!job.internal) {
    const size_t mine = per_owner_.count(job.owner) != 0 ? per_owner_[job.owner] : 0;
    std::string why;
    if (mine >= options_.max_subscriptions_per_session) {
      refusals_.count("max_subscriptions_per_session");
      why = "this session already has " + std::to_string(mine) + " subscriptions (max_subscriptions_per_session " +
            std::to_string(options_.max_subscriptions_per_session) + ")";
    } else {
      why = peer_subscriptions_.take(job.holder, 1);
    }
    if (!why.empty()) {
      ack.set_status(planet::RESOURCE_EXHAUSTED);
      ack.set_message("subscription to " + quote_prefix(job.pattern.text()) + " not accepted: " + why);
      send_ack();
      return;
    }
  }
  ack.set_status(planet::OK);
  ack.set_oldest_retained_seq(oldest_seq_.load());
  ack.set_last_seq(last_seq_.load());
  send_ack();

  // Replay, then go live. Both happen on this thread, so no live event can slip in between.
  const TopicPattern& pattern = job.pattern;
  bool replay = job.resume_after > 0 || job.internal;
  if (replay && job.resume_after < last_seq_.load()) {
    try {
      Statement replay(db_,
                       "SELECT seq, topic, payload, content_type, source, time_ns, traceparent FROM events "
                       "WHERE seq > ? ORDER BY seq");
      replay.bind(1, static_cast<int64_t>(job.resume_after));
      while (replay.step()) {
        std::string topic = replay.column_text(1);
        if (!pattern.matches(topic)) continue;
        planet::Event event;
        event.set_subscription_id(job.subscription_id);
        event.set_seq(static_cast<uint64_t>(replay.column_int(0)));
        event.set_topic(topic);
        event.set_payload(replay.column_blob(2));
        event.set_content_type(replay.column_text(3));
        event.set_source(replay.column_text(4));
        event.set_time_unix_ns(replay.column_int(5));
        event.set_traceparent(replay.column_text(6));
        if (!hand(job.deliver, event)) {  // receiver gone
          if (!job.internal) peer_subscriptions_.give(job.holder, 1);
          return;
        }
      }
    } catch (const SqliteError& e) {
      spdlog::error("replay for subscription {} ({}) failed: {}", job.subscription_id, quote_prefix(pattern.text()),
                    e.what());
    }
  }
  index_.insert(pattern, key);
  subscriptions_.emplace(key, Subscription{pattern, std::move(job.deliver), job.holder});
  subscription_count_ = subscriptions_.size();
  if (!job.internal) ++per_owner_[job.owner];
}

call::Reply EventBus::publish_as(const std::string& source, const std::string& topic,
                                 const google::protobuf::Message& event) {
  PublishInput input;
  input.topic = topic;
  input.payload = event.SerializeAsString();
  input.content_type = event.GetTypeName();
  input.source = source;
  input.privileged = true;  // the server, or a task (defined and run by operators)
  // The call being served on this thread caused it (util::TraceScope), if any.
  if (const auto* trace = util::current_trace()) input.traceparent = trace->child().traceparent();
  auto refusal = std::make_shared<planet::PublishAck>();
  bool accepted = publish(std::move(input), [refusal, topic, source](const planet::PublishAck& ack) {
    if (ack.status() == planet::OK) return;
    *refusal = ack;  // read below only when refused synchronously
    spdlog::warn("event on '{}' from {} not stored: {}", topic, source, ack.message());
  });
  if (!accepted) {
    return call::Reply::error(call::status_from_number(refusal->status()).value_or(call::Status::INTERNAL),
                              refusal->message());
  }
  return call::Reply::success({});
}

call::Reply BusEventSink::publish(const std::string& topic, const google::protobuf::Message& event) {
  return bus_.publish_as(source_, topic, event);
}

}  // namespace urs::camus_server
