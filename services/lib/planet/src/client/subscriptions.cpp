#include "client/subscriptions.hpp"

#include <spdlog/spdlog.h>

#include <exception>
#include <utility>

namespace urs::planet::detail {

Subscriptions::Subscriptions(std::string target) : target_(std::move(target)) {}

void Subscriptions::send_subscribe_locked(uint64_t id, const Subscription& subscription) {
  if (!sink_) return;
  // A refused send needs nothing: the next session sends every subscription again.
  Frame frame;
  Subscribe& subscribe = *frame.mutable_subscribe();
  subscribe.set_subscription_id(id);
  subscribe.set_pattern(subscription.pattern);
  subscribe.set_resume_after_seq(subscription.last_seq);
  sink_->send(std::move(frame));
}

uint64_t Subscriptions::subscribe(const std::string& pattern, EventHandler handler, uint64_t resume_after_seq) {
  std::lock_guard<std::mutex> lock(mutex_);
  const uint64_t id = next_id_++;
  Subscription subscription;
  subscription.pattern = pattern;
  subscription.handler = std::make_shared<EventHandler>(std::move(handler));
  subscription.last_seq = resume_after_seq;
  send_subscribe_locked(id, subscription);
  subscriptions_.emplace(id, std::move(subscription));
  return id;
}

void Subscriptions::unsubscribe(uint64_t id) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (subscriptions_.erase(id) == 0) return;
  if (sink_) {
    Frame frame;
    frame.mutable_unsubscribe()->set_subscription_id(id);
    sink_->send(std::move(frame));
  }
  if (delivering_ == id && delivering_thread_ == std::this_thread::get_id()) return;  // from the handler
  delivered_.wait(lock, [&] { return delivering_ != id; });
}

void Subscriptions::open(std::shared_ptr<FrameSink> sink) {
  std::lock_guard<std::mutex> lock(mutex_);
  sink_ = std::move(sink);
  for (const auto& [id, subscription] : subscriptions_) send_subscribe_locked(id, subscription);
}

void Subscriptions::detach() {
  std::lock_guard<std::mutex> lock(mutex_);
  sink_.reset();
}

void Subscriptions::on_event(const Event& event) {
  std::shared_ptr<EventHandler> handler;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = subscriptions_.find(event.subscription_id());
    if (it == subscriptions_.end()) return;          // unsubscribed meanwhile
    if (event.seq() <= it->second.last_seq) return;  // duplicate (replayed after a resume)
    it->second.last_seq = event.seq();
    handler = it->second.handler;
    delivering_ = event.subscription_id();  // unsubscribe() waits for it
    delivering_thread_ = std::this_thread::get_id();
  }
  if (handler && *handler) {
    try {
      (*handler)(event);
    } catch (const std::exception& exception) {
      spdlog::error("planet: event handler for '{}' threw: {}", event.topic(), exception.what());
    }
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    delivering_ = 0;
    delivering_thread_ = std::thread::id();
  }
  delivered_.notify_all();
}

void Subscriptions::on_ack(const SubscribeAck& ack) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = subscriptions_.find(ack.subscription_id());
  if (it == subscriptions_.end()) return;
  Subscription& subscription = it->second;
  if (ack.status() != Status::OK) {
    spdlog::error("planet: subscription to '{}' refused: {}: {}", subscription.pattern, status_name(ack.status()),
                  ack.message());
    return;
  }
  if (subscription.last_seq > 0 && ack.oldest_retained_seq() > subscription.last_seq + 1) {
    spdlog::warn("planet: events {}..{} on '{}' are no longer retained by {}; they are lost", subscription.last_seq + 1,
                 ack.oldest_retained_seq() - 1, subscription.pattern, target_);
  }
  if (subscription.last_seq == 0) {
    // "Only new events": resume after what was current when subscribing.
    subscription.last_seq = ack.last_seq();
  } else if (ack.last_seq() < subscription.last_seq) {
    spdlog::warn("planet: {} restarted its event sequence (now {}, had {}); resuming there", target_, ack.last_seq(),
                 subscription.last_seq);
    subscription.last_seq = ack.last_seq();
  }
}

}  // namespace urs::planet::detail
