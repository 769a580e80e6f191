#pragma once
// The event system: sequencing, a bounded retention log, pattern subscriptions, resume.
//
//  - Every accepted event gets a server-wide, strictly increasing seq. It is written to the
//    retention log (SQLite) before anyone sees it; the log keeps the newest `retention` events.
//    Seq continues after the stored maximum across restarts.
//  - An event is acknowledged after it is stored and handed to its subscribers, so a publisher
//    that waits for its acknowledgements feels a bus that is behind. Publishes and subscribes
//    of peers wait in a bounded queue: `event_queue` operations and `event_queue_bytes`, in fair
//    shares per credential (planet::FairShare: `event_queue_per_credential`,
//    `event_queue_bytes_per_credential`, a `reserved_percent` kept for sam and operator
//    credentials and the server's tasks) and at most `event_queue_per_session` from one
//    session; beyond them they are refused at once with RESOURCE_EXHAUSTED naming the limit.
//    Nothing acknowledged OK is ever dropped.
//  - Publishes of a session are deduplicated by (publisher, publish_id) for the life of this
//    process: publish ids of a session start at 1 and increase; a resent duplicate is
//    acknowledged with the original seq and not delivered again. The ids of `max_publishers`
//    sessions are remembered, in fair shares per credential (planet::FairQueue): one
//    credential's sessions push out only their own while another stays within its share.
//  - Only the server speaks as the server: an event whose source is kServerPeerName may go on
//    the server's own first levels (kServerTopics: registry, context, task) and is not counted.
//    Every other publisher (a session, a task publishing as its owner) gets PERMISSION_DENIED
//    there and the topic limits.
//  - Subscribers get matching events in seq order. Subscribe with resume_after_seq = N first
//    replays retained matching events with seq > N, then live ones, with no duplicate, loss or
//    reordering across the switch. Patterns are kept in a TopicIndex: matching an event costs
//    what its topic reaches, not one test per subscription. Subscriptions are bounded per
//    session, and per credential and in total in fair shares; topics and patterns by TopicLimits.
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
#include "urs/planet/fair_share.hpp"

namespace urs::camus_server {

struct EventBusOptions {
  uint64_t retention = 100000;                            // events kept in the log
  size_t event_queue = 10000;                             // publishes + subscribes of peers waiting
  size_t event_queue_per_credential = 2500;               // of one credential
  size_t event_queue_per_session = 1000;                  // of one session
  size_t event_queue_bytes = 64ull << 20;                 // their topics, payloads and patterns
  size_t event_queue_bytes_per_credential = 32ull << 20;  // of one credential
  size_t batch = 256;                                     // publishes stored per transaction
  TopicLimits topics;                                     // topics and patterns
  size_t max_subscriptions_per_session = 1000;
  size_t max_subscriptions_per_credential = 2500;
  size_t max_subscriptions = 20000;  // all peers together (the server's own not counted)
  size_t dedupe_window = 4096;       // publish ids remembered per publishing session
  size_t max_publishers = 1024;      // publishing sessions remembered
  size_t max_publishers_per_credential = 256;
  unsigned reserved_percent = 20;  // of each server-wide limit, kept for sam, operator and tasks
};

struct PublishInput {
  std::string topic;
  std::string payload;
  std::string content_type;
  // The publisher's authenticated identity (Event.source): a session's credential, a task's
  // owner, or kServerPeerName for the server's own events (the only ones on server topics).
  std::string source;
  bool privileged = false;  // role sam or operator (or a task): may use the reserved share
  uint64_t publisher = 0;   // the publishing session (planet::Identity::session); 0 = none
  uint64_t publish_id = 0;  // from 1, increasing per session; ignored without a session
  // The trace of the call that caused it (a valid W3C traceparent, urs/util/trace.hpp), or empty;
  // delivered and stored with the event (Event.traceparent).
  std::string traceparent;
};

// What the bus has done and holds, for the server's metrics.
struct EventBusStats {
  uint64_t published = 0;  // events sequenced and stored
  uint64_t delivered = 0;  // events handed to subscribers (live and replayed), one per subscriber
  uint64_t dropped = 0;    // deliveries a subscriber could not take (its session gone or closing)
  size_t queued = 0;       // operations waiting for the bus thread
  uint64_t queued_bytes = 0;
  size_t subscriptions = 0;
  // By the limit that refused: event_queue(_per_session, _per_credential), event_queue_bytes(...),
  // max_subscriptions(_per_session, _per_credential).
  std::vector<std::pair<std::string, uint64_t>> refusals;
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
  // Publishes `event` (content type: its full name) on `topic` with `source`: kServerPeerName for
  // the server's own events; any other source (a task's owner) under a peer's rules (topic
  // limits, never on a server topic, counted in the queue's reserved share). Never blocks:
  // success once queued, else the refusal (a refusal after queueing is logged).
  virtual call::Reply publish_as(const std::string& source, const std::string& topic,
                                 const google::protobuf::Message& event) = 0;
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
  // `owner` groups subscriptions (a session id); ids are unique per owner. `subscriber` is whose
  // share they count in (empty credential: "session <owner>", a client). The ack comes first,
  // then replayed events, then live ones. Refusals: BAD_ARGUMENTS (pattern), RESOURCE_EXHAUSTED
  // (queue full, subscription limits), ALREADY_EXISTS (id in use).
  void subscribe(uint64_t owner, const planet::Subscribe& request, DeliverFn deliver, SubscribeAckFn ack,
                 const planet::ShareHolder& subscriber = {});
  void unsubscribe(uint64_t owner, uint64_t subscription_id);
  void drop_owner(uint64_t owner);

  // Blocks until every operation queued before the call has been carried out. Not from the bus
  // thread.
  void flush();
  // Processes what is queued, then stops the thread. Later operations are refused. Idempotent.
  void stop();

  uint64_t oldest_retained_seq() const;
  size_t subscriptions() const;  // of sessions and of the server
  EventBusStats stats() const;   // thread-safe

  // EventSource
  uint64_t last_seq() const override { return last_seq_.load(); }
  uint64_t subscribe_internal(const TopicPattern& pattern, uint64_t resume_after_seq, DeliverFn deliver) override;
  void unsubscribe_internal(uint64_t handle) override;
  call::Reply publish_as(const std::string& source, const std::string& topic,
                         const google::protobuf::Message& event) override;

 private:
  struct Job;
  struct Subscription {
    TopicPattern pattern;
    DeliverFn deliver;
    planet::ShareHolder subscriber;  // whose share it counts in (a peer's; none for the server's)
  };
  using SubKey = TopicIndex::Key;  // (owner, subscription id)
  // Publish ids of one session: the highest accepted, the seqs of the newest `dedupe_window`
  // ones (ascending), and its place in the least-recently-publishing order.
  struct PublisherIds {
    uint64_t last = 0;
    std::deque<std::pair<uint64_t, uint64_t>> recent;  // (publish id, seq)
  };

  bool enqueue(Job job);
  void refuse(Job& job, planet::Status status, const std::string& why);
  void run();
  void process_publishes(std::vector<Job>& batch);
  void process_subscribe(Job& job);
  void remove_subscription(std::map<SubKey, Subscription>::iterator it);
  void deliver_live(const planet::Event& event);
  // Hands `event` to a subscriber, counting it; false once the subscriber is gone.
  bool hand(const DeliverFn& deliver, const planet::Event& event);
  void remember_id(const PublishInput& input, uint64_t seq);
  void forget_id(uint64_t publisher, uint64_t publish_id);

  EventBusOptions options_;
  const Clock& clock_;
  Database db_;
  std::atomic<uint64_t> last_seq_{0};
  std::atomic<uint64_t> oldest_seq_{1};
  std::atomic<uint64_t> next_internal_{0};

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable idle_;
  std::deque<Job> queue_;
  // Operations of peers in queue_ or being processed, and their bytes, by credential.
  planet::FairShare queued_;
  planet::FairShare queued_bytes_;
  std::unordered_map<uint64_t, size_t> queued_by_session_;  // by Job::budget
  planet::Refusals refusals_;                               // by the bus's own limits (the shares count theirs)
  std::atomic<uint64_t> published_{0};
  std::atomic<uint64_t> delivered_{0};
  std::atomic<uint64_t> dropped_{0};
  uint64_t enqueued_ = 0;
  uint64_t done_ = 0;
  bool stopping_ = false;
  bool stopped_ = false;

  // Bus thread only (subscription_count_ also read by subscriptions()).
  std::map<SubKey, Subscription> subscriptions_;
  TopicIndex index_;
  std::unordered_map<uint64_t, size_t> per_owner_;  // sessions' subscriptions per owner
  planet::FairShare peer_subscriptions_;            // by credential
  std::atomic<size_t> subscription_count_{0};
  std::unordered_map<uint64_t, PublisherIds> publishers_;
  planet::FairQueue publisher_order_;  // of publishers_, least recently publishing first

  std::thread thread_;
};

// agent::EventSink over the bus, for publishers inside the server (registry, context, tasks).
class BusEventSink final : public agent::EventSink {
 public:
  explicit BusEventSink(EventBus& bus, std::string source = kServerPeerName) : bus_(bus), source_(std::move(source)) {}
  call::Reply publish(const std::string& topic, const google::protobuf::Message& event) override;

 private:
  EventBus& bus_;
  std::string source_;
};

}  // namespace urs::camus_server
