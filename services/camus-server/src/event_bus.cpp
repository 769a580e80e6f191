#include "urs/camus_server/event_bus.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <utility>

namespace urs::camus_server {

namespace {
constexpr uint64_t kInternalOwnerBit = 1ull << 63;
constexpr uint64_t kConnectionBudgetBit = 1ull << 62;  // subscribes count per connection, publishes per session
}

struct EventBus::Job {
  enum class Kind { Publish, Subscribe, Unsubscribe, DropOwner, Flush };
  Kind kind = Kind::Flush;
  size_t bytes = 0;      // counted against event_queue_bytes (with `counted`)
  bool counted = false;  // an operation of a session, counted against event_queue
  uint64_t budget = 0;   // whose share of event_queue_per_session it uses
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
    : options_(options), clock_(clock), db_(db_path, Durability::Normal) {
  if (options_.retention == 0) options_.retention = 1;
  db_.exec(
      "CREATE TABLE IF NOT EXISTS events (seq INTEGER PRIMARY KEY, topic TEXT NOT NULL, payload BLOB, "
      "content_type TEXT, source TEXT, time_ns INTEGER);"
      "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value INTEGER);");
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
  if (stopping_) {
    status = planet::UNAVAILABLE;
    why = "server is shutting down";
  } else if (job.counted && queued_ >= options_.event_queue) {
    status = planet::RESOURCE_EXHAUSTED;
    why = "the event bus is behind: " + std::to_string(queued_) + " operations are queued (event_queue " +
          std::to_string(options_.event_queue) + "); retry later";
  } else if (job.counted && queued_by_session_[job.budget] >= options_.event_queue_per_session) {
    status = planet::RESOURCE_EXHAUSTED;
    why = "the event bus is behind: this session has " + std::to_string(queued_by_session_[job.budget]) +
          " operations queued (event_queue_per_session " + std::to_string(options_.event_queue_per_session) +
          "); retry later";
  } else if (job.counted && queued_bytes_ + job.bytes > options_.event_queue_bytes) {
    status = planet::RESOURCE_EXHAUSTED;
    why = "the event bus is behind: " + std::to_string(queued_bytes_) + " bytes are queued and this adds " +
          std::to_string(job.bytes) + " (event_queue_bytes " + std::to_string(options_.event_queue_bytes) +
          "); retry later";
  }
  if (status == planet::OK) {
    if (job.counted) {
      ++queued_;
      queued_bytes_ += job.bytes;
      ++queued_by_session_[job.budget];
    }
    queue_.push_back(std::move(job));
    ++enqueued_;
    wake_.notify_one();
    return true;
  }
  if (job.counted && queued_by_session_[job.budget] == 0) queued_by_session_.erase(job.budget);
  lock.unlock();
  refuse(job, status, why);
  return false;
}

bool EventBus::publish(PublishInput input, PublishAckFn ack) {
  Job job;
  job.kind = Job::Kind::Publish;
  job.bytes = input.topic.size() + input.payload.size() + input.content_type.size();
  job.counted = input.publisher != 0;
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
  if (auto why = topic_problem(in.topic, in.publisher != 0 ? options_.topics : unbounded); !why.empty()) {
    refuse(job, planet::BAD_ARGUMENTS, "the topic is not valid: " + why);
    return false;
  }
  if (in.publisher != 0 && is_server_topic(in.topic)) {
    refuse(job, planet::PERMISSION_DENIED,
           "topics under '" + in.topic.substr(0, in.topic.find('/')) +
               "/' are published by the server alone (registry/, context/ and task/ are server topics)");
    return false;
  }
  return enqueue(std::move(job));
}

void EventBus::subscribe(uint64_t owner, const planet::Subscribe& request, DeliverFn deliver, SubscribeAckFn ack) {
  Job job;
  job.kind = Job::Kind::Subscribe;
  job.counted = true;
  job.bytes = request.pattern().size();
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
      --queued_;
      queued_bytes_ -= job.bytes;
      auto share = queued_by_session_.find(job.budget);
      if (share != queued_by_session_.end() && --share->second == 0) queued_by_session_.erase(share);
    }
    done_ += jobs.size();
    idle_.notify_all();
  }
}

void EventBus::remember_id(uint64_t publisher, uint64_t publish_id, uint64_t seq) {
  auto [it, added] = publishers_.try_emplace(publisher);
  PublisherIds& ids = it->second;
  if (added) {
    publisher_order_.push_front(publisher);
  } else {
    publisher_order_.splice(publisher_order_.begin(), publisher_order_, ids.lru);
  }
  ids.lru = publisher_order_.begin();
  // Ids arrive increasing; one below `last` fills a gap (an id never accepted before).
  auto at = std::lower_bound(ids.recent.begin(), ids.recent.end(), std::make_pair(publish_id, uint64_t{0}));
  ids.recent.insert(at, {publish_id, seq});
  ids.last = std::max(ids.last, publish_id);
  while (ids.recent.size() > options_.dedupe_window) ids.recent.pop_front();
  while (publishers_.size() > options_.max_publishers) {
    publishers_.erase(publisher_order_.back());
    publisher_order_.pop_back();
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
                     "INSERT INTO events (seq, topic, payload, content_type, source, time_ns) "
                     "VALUES (?, ?, ?, ?, ?, ?)");
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
          .bind(6, now);
      insert.step();
      insert.reset();
      out.ack.set_seq(seq);
      out.deliver = true;
      out.event.set_seq(seq);
      out.event.set_topic(std::move(in.topic));
      out.event.set_payload(std::move(in.payload));
      out.event.set_content_type(std::move(in.content_type));
      out.event.set_source(std::move(in.source));
      out.event.set_time_unix_ns(now);
      if (dedupe) {
        remember_id(in.publisher, in.publish_id, seq);
        new_ids.emplace_back(in.publisher, in.publish_id);
      }
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
    --session_subscriptions_;
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
    if (!it->second.deliver(copy)) remove_subscription(it);
  }
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
      why = "this session already has " + std::to_string(mine) + " subscriptions (max_subscriptions_per_session " +
            std::to_string(options_.max_subscriptions_per_session) + ")";
    } else if (session_subscriptions_ >= options_.max_subscriptions) {
      why = "the server already holds " + std::to_string(session_subscriptions_) +
            " subscriptions (max_subscriptions " + std::to_string(options_.max_subscriptions) + ")";
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
                       "SELECT seq, topic, payload, content_type, source, time_ns FROM events "
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
        if (!job.deliver(event)) return;  // receiver gone
      }
    } catch (const SqliteError& e) {
      spdlog::error("replay for subscription {} ({}) failed: {}", job.subscription_id, quote_prefix(pattern.text()),
                    e.what());
    }
  }
  index_.insert(pattern, key);
  subscriptions_.emplace(key, Subscription{pattern, std::move(job.deliver)});
  subscription_count_ = subscriptions_.size();
  if (!job.internal) {
    ++per_owner_[job.owner];
    ++session_subscriptions_;
  }
}

call::Reply BusEventSink::publish(const std::string& topic, const google::protobuf::Message& event) {
  PublishInput input;
  input.topic = topic;
  input.payload = event.SerializeAsString();
  input.content_type = event.GetTypeName();
  input.source = source_;
  auto refusal = std::make_shared<std::string>();
  bool accepted = bus_.publish(std::move(input), [refusal, topic](const planet::PublishAck& ack) {
    if (ack.status() == planet::OK) return;
    *refusal = ack.message();  // read below only when refused synchronously
    spdlog::warn("internal event on '{}' not stored: {}", topic, ack.message());
  });
  if (!accepted) return call::Reply::error(call::Status::UNAVAILABLE, *refusal);
  return call::Reply::success({});
}

}  // namespace urs::camus_server
