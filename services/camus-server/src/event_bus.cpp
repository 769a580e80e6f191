#include "urs/camus_server/event_bus.hpp"

#include <spdlog/spdlog.h>

#include <utility>

namespace urs::camus_server {

namespace {
constexpr uint64_t kInternalOwnerBit = 1ull << 63;
}

struct EventBus::Job {
  enum class Kind { Publish, Subscribe, Unsubscribe, DropOwner, Flush };
  Kind kind = Kind::Flush;
  // Publish
  PublishInput input;
  PublishAckFn publish_ack;
  // Subscribe / Unsubscribe / DropOwner
  uint64_t owner = 0;
  uint64_t subscription_id = 0;
  uint64_t resume_after = 0;
  std::string pattern_text;
  TopicPattern pattern;
  bool parsed = false;  // internal subscriptions come with a parsed pattern
  bool replay_from_zero = false;  // internal: resume_after 0 replays everything retained
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

bool EventBus::enqueue(Job job, bool refuse_when_full) {
  std::unique_lock<std::mutex> lock(mutex_);
  std::string why;
  if (stopping_) {
    why = "server is shutting down";
  } else if (refuse_when_full && queue_.size() >= options_.max_queue) {
    why = "event bus is overloaded (" + std::to_string(options_.max_queue) + " operations queued); retry later";
  }
  if (why.empty()) {
    queue_.push_back(std::move(job));
    ++enqueued_;
    wake_.notify_one();
    return true;
  }
  lock.unlock();
  if (job.kind == Job::Kind::Publish && job.publish_ack) {
    planet::PublishAck ack;
    ack.set_publish_id(job.input.publish_id);
    ack.set_status(planet::UNAVAILABLE);
    ack.set_message("event on '" + job.input.topic + "' not accepted: " + why);
    job.publish_ack(ack);
  } else if (job.kind == Job::Kind::Subscribe && job.subscribe_ack) {
    planet::SubscribeAck ack;
    ack.set_subscription_id(job.subscription_id);
    ack.set_status(planet::UNAVAILABLE);
    ack.set_message("subscription to '" + job.pattern_text + "' not accepted: " + why);
    job.subscribe_ack(ack);
  }
  return false;
}

bool EventBus::publish(PublishInput input, PublishAckFn ack) {
  Job job;
  job.kind = Job::Kind::Publish;
  job.input = std::move(input);
  job.publish_ack = std::move(ack);
  return enqueue(std::move(job), true);
}

void EventBus::subscribe(uint64_t owner, const planet::Subscribe& request, DeliverFn deliver, SubscribeAckFn ack) {
  Job job;
  job.kind = Job::Kind::Subscribe;
  job.owner = owner;
  job.subscription_id = request.subscription_id();
  job.resume_after = request.resume_after_seq();
  job.pattern_text = request.pattern();
  job.deliver = std::move(deliver);
  job.subscribe_ack = std::move(ack);
  enqueue(std::move(job), false);
}

uint64_t EventBus::subscribe_internal(const TopicPattern& pattern, uint64_t resume_after_seq, DeliverFn deliver) {
  uint64_t owner = kInternalOwnerBit | ++next_internal_;
  Job job;
  job.kind = Job::Kind::Subscribe;
  job.owner = owner;
  job.subscription_id = owner;
  job.resume_after = resume_after_seq;
  job.pattern_text = pattern.text();
  job.pattern = pattern;
  job.parsed = true;
  job.replay_from_zero = true;
  job.deliver = std::move(deliver);
  enqueue(std::move(job), false);
  return owner;
}

void EventBus::unsubscribe_internal(uint64_t handle) { drop_owner(handle); }

void EventBus::unsubscribe(uint64_t owner, uint64_t subscription_id) {
  Job job;
  job.kind = Job::Kind::Unsubscribe;
  job.owner = owner;
  job.subscription_id = subscription_id;
  enqueue(std::move(job), false);
}

void EventBus::drop_owner(uint64_t owner) {
  Job job;
  job.kind = Job::Kind::DropOwner;
  job.owner = owner;
  enqueue(std::move(job), false);
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

void EventBus::run() {
  for (;;) {
    std::deque<Job> jobs;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping and drained
      jobs.swap(queue_);
    }
    size_t count = jobs.size();
    std::vector<Job> batch;
    for (auto& job : jobs) {
      if (job.kind == Job::Kind::Publish) {
        batch.push_back(std::move(job));
        continue;
      }
      if (!batch.empty()) {
        process_publishes(batch);
        batch.clear();
      }
      switch (job.kind) {
        case Job::Kind::Subscribe:
          process_subscribe(job);
          break;
        case Job::Kind::Unsubscribe:
          subscriptions_.erase({job.owner, job.subscription_id});
          break;
        case Job::Kind::DropOwner:
          for (auto it = subscriptions_.lower_bound({job.owner, 0});
               it != subscriptions_.end() && it->first.first == job.owner;) {
            it = subscriptions_.erase(it);
          }
          break;
        default:
          break;
      }
    }
    if (!batch.empty()) process_publishes(batch);
    std::lock_guard<std::mutex> lock(mutex_);
    done_ += count;
    idle_.notify_all();
  }
}

void EventBus::process_publishes(std::vector<Job>& batch) {
  struct Outcome {
    planet::PublishAck ack;
    bool deliver = false;
    planet::Event event;
  };
  std::vector<Outcome> outcomes(batch.size());
  std::vector<std::pair<std::string, uint64_t>> new_ids;  // dedupe entries added by this batch
  uint64_t seq = last_seq_.load();
  const int64_t now = clock_.now_unix_ns();
  std::string failure;
  try {
    Transaction tx(db_);
    Statement insert(db_,
                     "INSERT INTO events (seq, topic, payload, content_type, source, time_ns) "
                     "VALUES (?, ?, ?, ?, ?, ?)");
    for (size_t i = 0; i < batch.size(); ++i) {
      const PublishInput& in = batch[i].input;
      Outcome& out = outcomes[i];
      out.ack.set_publish_id(in.publish_id);
      if (auto why = topic_problem(in.topic); !why.empty()) {
        out.ack.set_status(planet::BAD_ARGUMENTS);
        out.ack.set_message("topic '" + in.topic + "' is not valid: " + why);
        continue;
      }
      bool dedupe = !in.session_key.empty() && in.publish_id != 0;
      if (dedupe) {
        auto& seen = dedupe_[in.session_key];
        auto it = seen.find(in.publish_id);
        if (it != seen.end()) {
          out.ack.set_seq(it->second);  // a resent duplicate: same seq, not delivered again
          continue;
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
      out.event.set_topic(in.topic);
      out.event.set_payload(in.payload);
      out.event.set_content_type(in.content_type);
      out.event.set_source(in.source);
      out.event.set_time_unix_ns(now);
      if (dedupe) {
        dedupe_[in.session_key][in.publish_id] = seq;
        new_ids.emplace_back(in.session_key, in.publish_id);
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
    for (auto& [key, id] : new_ids) dedupe_[key].erase(id);
    for (size_t i = 0; i < batch.size(); ++i) {
      Outcome& out = outcomes[i];
      if (out.deliver) {
        out.deliver = false;
        out.ack.set_seq(0);
        out.ack.set_status(planet::INTERNAL);
        out.ack.set_message("event on '" + batch[i].input.topic + "' not stored: " + failure);
      }
    }
  } else {
    if (seq > last_seq_.load()) {
      if (oldest_seq_.load() > seq) oldest_seq_ = last_seq_.load() + 1;  // log was empty
      if (seq > options_.retention) oldest_seq_ = std::max(oldest_seq_.load(), seq - options_.retention + 1);
      last_seq_ = seq;
    }
    // Bound the dedupe memory: drop the oldest ids of a key beyond the window.
    for (auto& [key, id] : new_ids) {
      auto& seen = dedupe_[key];
      while (seen.size() > options_.dedupe_window) seen.erase(seen.begin());
    }
  }

  for (size_t i = 0; i < batch.size(); ++i) {
    if (batch[i].publish_ack) batch[i].publish_ack(outcomes[i].ack);
  }
  for (auto& out : outcomes) {
    if (out.deliver) deliver_live(out.event);
  }
}

void EventBus::deliver_live(const planet::Event& event) {
  for (auto it = subscriptions_.begin(); it != subscriptions_.end();) {
    if (it->second.pattern.matches(event.topic())) {
      planet::Event copy = event;
      copy.set_subscription_id(it->first.second);
      if (!it->second.deliver(copy)) {
        it = subscriptions_.erase(it);
        continue;
      }
    }
    ++it;
  }
}

void EventBus::process_subscribe(Job& job) {
  planet::SubscribeAck ack;
  ack.set_subscription_id(job.subscription_id);
  auto send_ack = [&] {
    if (job.subscribe_ack) job.subscribe_ack(ack);
  };
  TopicPattern pattern = job.pattern;
  if (!job.parsed) {
    auto parsed = TopicPattern::parse(job.pattern_text);
    if (!parsed.ok()) {
      ack.set_status(parsed.status());
      ack.set_message(parsed.message());
      send_ack();
      return;
    }
    pattern = parsed.value();
  }
  SubKey key{job.owner, job.subscription_id};
  if (subscriptions_.count(key) != 0) {
    ack.set_status(planet::ALREADY_EXISTS);
    ack.set_message("subscription " + std::to_string(job.subscription_id) + " already exists on this session");
    send_ack();
    return;
  }
  ack.set_status(planet::OK);
  ack.set_oldest_retained_seq(oldest_seq_.load());
  ack.set_last_seq(last_seq_.load());
  send_ack();

  // Replay, then go live. Both happen on this thread, so no live event can slip in between.
  bool replay = job.resume_after > 0 || job.replay_from_zero;
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
      spdlog::error("replay for subscription {} ('{}') failed: {}", job.subscription_id, job.pattern_text, e.what());
    }
  }
  subscriptions_.emplace(key, Subscription{pattern, std::move(job.deliver)});
}

planet::CallResult BusEventSink::publish(const std::string& topic, const google::protobuf::Message& event) {
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
  if (!accepted) return planet::CallResult::error(planet::UNAVAILABLE, *refusal);
  return planet::CallResult::success({});
}

}  // namespace urs::camus_server
