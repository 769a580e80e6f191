#pragma once
// The client's subscriptions and their handlers.
//
// - Each subscription remembers the last event it delivered; when a session opens it is sent
//   again resuming after that event, and what the server replays twice is delivered once.
// - unsubscribe() returns once the handler runs no more, so what the handler uses may then be
//   destroyed (from within the handler itself there is nothing to wait for).
//
// Threading: thread-safe. on_event() runs the handler on the calling thread (the client's I/O
// thread) without the lock held.

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "client/frame_sink.hpp"
#include "urs/planet/client.hpp"

namespace urs::planet::detail {

class Subscriptions {
 public:
  // `target` ("host:port") names the server in logs.
  explicit Subscriptions(std::string target);

  // Returns the subscription id; sent at once if a session is open. `resume_after_seq` 0: only
  // events published from now on.
  uint64_t subscribe(const std::string& pattern, EventHandler handler, uint64_t resume_after_seq);
  // Forgets it (tells the server if a session is open) and waits until its handler runs no more.
  void unsubscribe(uint64_t id);

  // A session opened on `sink`: every subscription is sent again, resuming after its last event.
  void open(std::shared_ptr<FrameSink> sink);
  void detach();

  // An event from the server: runs the handler of its subscription unless it was unsubscribed or
  // the event was already delivered.
  void on_event(const Event& event);
  // The server's answer to a Subscribe: logs a refusal or a gap; sets where "only new events" start.
  void on_ack(const SubscribeAck& ack);

 private:
  struct Subscription {
    std::string pattern;
    std::shared_ptr<EventHandler> handler;
    uint64_t last_seq = 0;
  };
  void send_subscribe_locked(uint64_t id, const Subscription& subscription);

  const std::string target_;
  mutable std::mutex mutex_;
  std::condition_variable delivered_;
  std::shared_ptr<FrameSink> sink_;  // null: no session
  uint64_t next_id_ = 1;
  std::map<uint64_t, Subscription> subscriptions_;
  uint64_t delivering_ = 0;            // the subscription whose handler runs now, or 0
  std::thread::id delivering_thread_;  // the thread that runs it
};

}  // namespace urs::planet::detail
