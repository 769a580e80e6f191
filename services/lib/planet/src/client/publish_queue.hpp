#pragma once
// The client's publishes until the server acknowledges them (at least once).
//
// - A publish is kept, counted in the QueueBudget, from publish() until its PublishAck; sent at once
//   while a session is open, and (re)sent in order when the next session opens. The server drops
//   duplicates within its lifetime.
// - publish_and_wait() blocks until the acknowledgement of its own event.
//
// Threading: thread-safe; nothing here runs a user callback.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "client/frame_sink.hpp"
#include "client/queue_budget.hpp"
#include "urs/planet/status.hpp"

namespace urs::planet::detail {

class PublishQueue {
 public:
  explicit PublishQueue(QueueBudget& budget);

  // UNAVAILABLE if the budget is full or the queue closed; PAYLOAD_TOO_LARGE if a session is open
  // and its server would refuse the size; OK once kept (and sent, if a session is open).
  CallResult publish(const std::string& topic, std::string payload, const std::string& content_type);
  // The same, then blocks until the server acknowledges this event: OK, the server's refusal, or
  // DEADLINE_EXCEEDED after `timeout` (the event stays queued), UNAVAILABLE if closed meanwhile.
  CallResult publish_and_wait(const std::string& topic, std::string payload, const std::string& content_type,
                              std::chrono::milliseconds timeout);

  // A session opened on `sink` (server limit `send_limit` bytes): resends what is unacknowledged,
  // in order, dropping (with an error log) what that server would refuse as too large.
  void open(std::shared_ptr<FrameSink> sink, uint64_t send_limit);
  void detach();
  void on_ack(const PublishAck& ack);
  // Drops what is unacknowledged (logged) and refuses later publishes; waiters get UNAVAILABLE.
  void close();

  size_t unacknowledged() const;

 private:
  // With mutex_ held: `id` receives the publish id.
  CallResult publish_locked(const std::string& topic, std::string payload, const std::string& content_type,
                            uint64_t& id);
  // With mutex_ held: whether the current server takes `publish` (size with the frame's envelope).
  bool fits_locked(const Publish& publish) const;
  void send_locked(const Publish& publish);

  QueueBudget& budget_;
  mutable std::mutex mutex_;
  std::condition_variable acked_;
  std::shared_ptr<FrameSink> sink_;  // null: no session
  uint64_t send_limit_ = UINT64_MAX;
  bool closed_ = false;
  uint64_t next_id_ = 1;
  std::map<uint64_t, Publish> unacked_;     // by publish_id: resent in order after a reconnect
  std::map<uint64_t, PublishAck> awaited_;  // acks publish_and_wait() waits for
};

}  // namespace urs::planet::detail
