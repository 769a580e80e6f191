#pragma once
// The event system: sequencing, a bounded retention log, pattern subscriptions, resume.
//
//  - Every accepted event gets a server-wide, strictly increasing seq. It is written to the
//    retention log (SQLite) before it is acknowledged and before anyone sees it; the log keeps
//    the newest `retention` events. Seq continues after the stored maximum across restarts.
//  - Publishes carrying (session_key, publish_id) are deduplicated for the life of this process:
//    a resent duplicate is acknowledged with the original seq and not delivered again.
//  - Subscribers get matching events in seq order. Subscribe with resume_after_seq = N first
//    replays retained matching events with seq > N, then live ones, with no duplicate, loss or
//    reordering across the switch.
//
// Threading: every operation is queued to the bus's own thread and returns at once; that thread
// writes (publishes queued together share one transaction), then acknowledges, then delivers.
// Callbacks (acks, deliveries) run on the bus thread and must not block or call flush().

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "planet.pb.h"
#include "urs/agent/agent.hpp"
#include "urs/camus_server/clock.hpp"
#include "urs/camus_server/sqlite.hpp"
#include "urs/camus_server/topic_pattern.hpp"

namespace urs::camus_server {

struct EventBusOptions {
  uint64_t retention = 100000;      // events kept in the log
  size_t max_queue = 100000;        // queued operations before publishes are refused UNAVAILABLE
  size_t dedupe_window = 65536;     // publish ids remembered per session key
};

struct PublishInput {
  std::string topic;
  std::string payload;
  std::string content_type;
  std::string source;        // the publisher's peer name
  std::string session_key;   // Hello.session_id; empty = no deduplication
  uint64_t publish_id = 0;   // 0 = no deduplication
};

using PublishAckFn = std::function<void(const planet::PublishAck&)>;
// Delivers one event (subscription_id already set); returns false once the receiver is gone,
// which ends the subscription.
using DeliverFn = std::function<bool(const planet::Event&)>;
using SubscribeAckFn = std::function<void(const planet::SubscribeAck&)>;

// What the task manager needs of the bus.
class EventSource {
 public:
  virtual ~EventSource() = default;
  virtual uint64_t last_seq() const = 0;
  // A subscription owned by the server itself: retained matching events with seq >
  // resume_after_seq (also when it is 0), then live ones. `deliver` runs on the bus thread.
  virtual uint64_t subscribe_internal(const TopicPattern& pattern, uint64_t resume_after_seq, DeliverFn deliver) = 0;
  virtual void unsubscribe_internal(uint64_t handle) = 0;
};

class EventBus final : public EventSource {
 public:
  // Opens (or creates) the log at `db_path` ("" = in memory) and starts the bus thread.
  // Throws SqliteError naming the file.
  EventBus(const std::string& db_path, EventBusOptions options, const Clock& clock);
  ~EventBus() override;  // stop()
  EventBus(const EventBus&) = delete;
  EventBus& operator=(const EventBus&) = delete;

  // Never blocks. `ack` (may be empty) gets seq, or BAD_ARGUMENTS / UNAVAILABLE / INTERNAL.
  // Returns false if the event was refused at once (queue full or stopped; `ack` has been called).
  bool publish(PublishInput input, PublishAckFn ack);
  // `owner` groups subscriptions (a session id); ids are unique per owner. The ack comes first,
  // then replayed events, then live ones.
  void subscribe(uint64_t owner, const planet::Subscribe& request, DeliverFn deliver, SubscribeAckFn ack);
  void unsubscribe(uint64_t owner, uint64_t subscription_id);
  void drop_owner(uint64_t owner);

  // Blocks until every operation queued before the call has been carried out. Not from the bus
  // thread.
  void flush();
  // Processes what is queued, then stops the thread. Later operations are refused. Idempotent.
  void stop();

  uint64_t oldest_retained_seq() const;

  // EventSource
  uint64_t last_seq() const override { return last_seq_.load(); }
  uint64_t subscribe_internal(const TopicPattern& pattern, uint64_t resume_after_seq, DeliverFn deliver) override;
  void unsubscribe_internal(uint64_t handle) override;

 private:
  struct Job;
  struct Subscription {
    TopicPattern pattern;
    DeliverFn deliver;
  };
  using SubKey = std::pair<uint64_t, uint64_t>;  // (owner, subscription id)

  bool enqueue(Job job, bool refuse_when_full);
  void run();
  void process_publishes(std::vector<Job>& batch);
  void process_subscribe(Job& job);
  void deliver_live(const planet::Event& event);

  EventBusOptions options_;
  const Clock& clock_;
  Database db_;
  std::atomic<uint64_t> last_seq_{0};
  std::atomic<uint64_t> oldest_seq_{1};
  std::atomic<uint64_t> next_internal_{0};

  std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable idle_;
  std::deque<Job> queue_;
  uint64_t enqueued_ = 0;
  uint64_t done_ = 0;
  bool stopping_ = false;
  bool stopped_ = false;

  // Bus thread only.
  std::map<SubKey, Subscription> subscriptions_;
  std::unordered_map<std::string, std::map<uint64_t, uint64_t>> dedupe_;  // key -> publish id -> seq

  std::thread thread_;
};

// agent::EventSink over the bus, for publishers inside the server (registry, context, tasks).
class BusEventSink final : public agent::EventSink {
 public:
  explicit BusEventSink(EventBus& bus, std::string source = "camus-server")
      : bus_(bus), source_(std::move(source)) {}
  planet::CallResult publish(const std::string& topic, const google::protobuf::Message& event) override;

 private:
  EventBus& bus_;
  std::string source_;
};

}  // namespace urs::camus_server
