#pragma once
// The event system: sequencing, a bounded retention log, pattern subscriptions, resume.
//
//  - Every accepted event gets a server-wide, strictly increasing seq. It is written to the
//    retention log (SQLite) before anyone sees it; the log keeps the newest `retention` events.
//    Seq continues after the stored maximum across restarts.
//  - An event is acknowledged after it is stored and handed to its subscribers, so a publisher
//    that waits for its acknowledgements feels a bus that is behind. Publishes and subscribes
//    from sessions wait in a bounded queue (`event_queue` operations, of which at most
//    `event_queue_per_session` from one session, and `event_queue_bytes`); beyond it they are
//    refused at once with RESOURCE_EXHAUSTED naming the limit. Nothing acknowledged OK is ever
//    dropped.
//  - Publishes of a session are deduplicated by (publisher, publish_id) for the life of this
//    process: publish ids of a session start at 1 and increase; a resent duplicate is
//    acknowledged with the original seq and not delivered again.
//  - Topics under the server's own first levels (kServerTopics: registry, context, task) are
//    published by the server alone (publisher 0); sessions get PERMISSION_DENIED.
//  - Subscribers get matching events in seq order. Subscribe with resume_after_seq = N first
//    replays retained matching events with seq > N, then live ones, with no duplicate, loss or
//    reordering across the switch. Patterns are kept in a TopicIndex: matching an event costs
//    what its topic reaches, not one test per subscription. Subscriptions are bounded per
//    session and in total; topics and patterns by TopicLimits.
//
// Threading: every operation is queued to the bus's own thread and returns at once; that thread
// writes (up to `batch` publishes share one transaction), then delivers and acknowledges each
// event. Callbacks (acks, deliveries) run on the bus thread and must not block or call flush();
// refusals decided at once (invalid topic, queue full) run on the caller's thread.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <list>
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
#include "urs/camus_server/names.hpp"
#include "urs/camus_server/sqlite.hpp"
#include "urs/camus_server/topic_index.hpp"
#include "urs/camus_server/topic_pattern.hpp"

namespace urs::camus_server {

struct EventBusOptions {
  uint64_t retention = 100000;                   // events kept in the log
  size_t event_queue = 10000;                    // publishes + subscribes of sessions waiting
  size_t event_queue_per_session = 1000;         // of one session: one peer cannot fill the queue
  size_t event_queue_bytes = 64ull << 20;        // their topics, payloads and patterns
  size_t batch = 256;                            // publishes stored per transaction
  TopicLimits topics;                            // topics and patterns
  size_t max_subscriptions_per_session = 1000;
  size_t max_subscriptions = 20000;              // all sessions together (the server's own not counted)
  size_t dedupe_window = 4096;                   // publish ids remembered per publishing session
  size_t max_publishers = 1024;                  // publishing sessions remembered (least recent forgotten)
};

struct PublishInput {
  std::string topic;
  std::string payload;
  std::string content_type;
  std::string source;        // the publisher's authenticated identity (Event.source)
  uint64_t publisher = 0;    // the publishing session (planet::Identity::session); 0 = the server
  uint64_t publish_id = 0;   // from 1, increasing per publisher; ignored for the server's events
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

  // Never blocks. `ack` (may be empty) gets seq, or BAD_ARGUMENTS (topic, publish_id 0),
  // PERMISSION_DENIED (a server topic), RESOURCE_EXHAUSTED (queue full), ALREADY_EXISTS (an id
  // older than the de-duplication window), UNAVAILABLE (stopping), INTERNAL (storage).
  // Returns false if the event was refused at once (`ack` has then been called on this thread).
  bool publish(PublishInput input, PublishAckFn ack);
  // `owner` groups subscriptions (a session id); ids are unique per owner. The ack comes first,
  // then replayed events, then live ones. Refusals: BAD_ARGUMENTS (pattern), RESOURCE_EXHAUSTED
  // (queue full, subscription limits), ALREADY_EXISTS (id in use).
  void subscribe(uint64_t owner, const planet::Subscribe& request, DeliverFn deliver, SubscribeAckFn ack);
  void unsubscribe(uint64_t owner, uint64_t subscription_id);
  void drop_owner(uint64_t owner);

  // Blocks until every operation queued before the call has been carried out. Not from the bus
  // thread.
  void flush();
  // Processes what is queued, then stops the thread. Later operations are refused. Idempotent.
  void stop();

  uint64_t oldest_retained_seq() const;
  size_t subscriptions() const;  // of sessions and of the server

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
  using SubKey = TopicIndex::Key;  // (owner, subscription id)
  // Publish ids of one session: the highest accepted, the seqs of the newest `dedupe_window`
  // ones (ascending), and its place in the least-recently-publishing order.
  struct PublisherIds {
    uint64_t last = 0;
    std::deque<std::pair<uint64_t, uint64_t>> recent;  // (publish id, seq)
    std::list<uint64_t>::iterator lru;
  };

  bool enqueue(Job job);
  void refuse(Job& job, planet::Status status, const std::string& why);
  void run();
  void process_publishes(std::vector<Job>& batch);
  void process_subscribe(Job& job);
  void remove_subscription(std::map<SubKey, Subscription>::iterator it);
  void deliver_live(const planet::Event& event);
  void remember_id(uint64_t publisher, uint64_t publish_id, uint64_t seq);
  void forget_id(uint64_t publisher, uint64_t publish_id);

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
  size_t queued_ = 0;        // operations of sessions in queue_ or being processed
  size_t queued_bytes_ = 0;  // their bytes
  std::unordered_map<uint64_t, size_t> queued_by_session_;  // by Job::budget
  uint64_t enqueued_ = 0;
  uint64_t done_ = 0;
  bool stopping_ = false;
  bool stopped_ = false;

  // Bus thread only (subscription_count_ also read by subscriptions()).
  std::map<SubKey, Subscription> subscriptions_;
  TopicIndex index_;
  std::unordered_map<uint64_t, size_t> per_owner_;  // sessions' subscriptions per owner
  size_t session_subscriptions_ = 0;
  std::atomic<size_t> subscription_count_{0};
  std::unordered_map<uint64_t, PublisherIds> publishers_;
  std::list<uint64_t> publisher_order_;  // most recently publishing first

  std::thread thread_;
};

// agent::EventSink over the bus, for publishers inside the server (registry, context, tasks).
class BusEventSink final : public agent::EventSink {
 public:
  explicit BusEventSink(EventBus& bus, std::string source = kServerPeerName)
      : bus_(bus), source_(std::move(source)) {}
  call::Reply publish(const std::string& topic, const google::protobuf::Message& event) override;

 private:
  EventBus& bus_;
  std::string source_;
};

}  // namespace urs::camus_server
