#include "client/publish_queue.hpp"

#include <spdlog/spdlog.h>

#include <utility>

#include "urs/util/trace.hpp"

namespace urs::planet::detail {

namespace {
// What a Frame adds around its Publish (tag and length), counted against the server's limit.
constexpr size_t kFrameEnvelopeBytes = 16;
}  // namespace

PublishQueue::PublishQueue(QueueBudget& budget) : budget_(budget) {}

bool PublishQueue::fits_locked(const Publish& publish) const {
  return publish.ByteSizeLong() + kFrameEnvelopeBytes <= send_limit_;
}

void PublishQueue::send_locked(const Publish& publish) {
  // A refused send leaves the publish here: the next session resends it.
  Frame frame;
  *frame.mutable_publish() = publish;
  if (sink_) sink_->send(std::move(frame));
}

CallResult PublishQueue::publish(const std::string& topic, std::string payload, const std::string& content_type) {
  std::lock_guard<std::mutex> lock(mutex_);
  uint64_t id = 0;
  return publish_locked(topic, std::move(payload), content_type, id);
}

CallResult PublishQueue::publish_locked(const std::string& topic, std::string payload, const std::string& content_type,
                                        uint64_t& id) {
  if (closed_) return CallResult::error(Status::UNAVAILABLE, "client stopped");
  if (!budget_.try_take()) return CallResult::error(Status::UNAVAILABLE, budget_.full_message(sink_ != nullptr));
  Publish publish;
  publish.set_publish_id(next_id_++);
  publish.set_topic(topic);
  publish.set_payload(std::move(payload));
  publish.set_content_type(content_type);
  // An event published while a call is served (util::TraceScope) carries that call's trace.
  if (const auto* trace = util::current_trace()) publish.set_traceparent(trace->child().traceparent());
  if (sink_) {
    if (!fits_locked(publish)) {
      budget_.give_back();
      return CallResult::error(Status::PAYLOAD_TOO_LARGE,
                               "publish of " + std::to_string(publish.ByteSizeLong() + kFrameEnvelopeBytes) +
                                   " bytes on '" + topic + "' exceeds the server's max_message_bytes " +
                                   std::to_string(send_limit_));
    }
    send_locked(publish);
  }
  id = publish.publish_id();
  unacked_.emplace(id, std::move(publish));
  return CallResult::success({});
}

CallResult PublishQueue::publish_and_wait(const std::string& topic, std::string payload,
                                          const std::string& content_type, std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  uint64_t id = 0;
  CallResult queued = publish_locked(topic, std::move(payload), content_type, id);
  if (!queued.ok()) return queued;
  // Registered under the same lock as the publish: the ack, handled under it too, cannot come before.
  awaited_.emplace(id, PublishAck());
  const bool acked = acked_.wait_for(lock, timeout, [&] { return awaited_.at(id).publish_id() == id || closed_; });
  const PublishAck ack = awaited_.at(id);
  awaited_.erase(id);
  if (!acked || ack.publish_id() != id) {
    return CallResult::error(
        closed_ ? Status::UNAVAILABLE : Status::DEADLINE_EXCEEDED,
        "no acknowledgement of the event on '" + topic + "' within " + std::to_string(timeout.count()) + " ms");
  }
  if (ack.status() != Status::OK) return CallResult::error(ack.status(), ack.message());
  return CallResult::success({});
}

void PublishQueue::open(std::shared_ptr<FrameSink> sink, uint64_t send_limit) {
  std::lock_guard<std::mutex> lock(mutex_);
  sink_ = std::move(sink);
  send_limit_ = send_limit;
  for (auto it = unacked_.begin(); it != unacked_.end();) {
    if (!fits_locked(it->second)) {
      spdlog::error("planet: dropping publish {} on '{}': {} bytes exceed the server's max_message_bytes {}", it->first,
                    it->second.topic(), it->second.ByteSizeLong(), send_limit_);
      it = unacked_.erase(it);
      budget_.give_back();
      continue;
    }
    send_locked(it->second);
    ++it;
  }
}

void PublishQueue::detach() {
  std::lock_guard<std::mutex> lock(mutex_);
  sink_.reset();
}

void PublishQueue::on_ack(const PublishAck& ack) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = unacked_.find(ack.publish_id());
  if (it == unacked_.end()) return;  // a duplicate ack after a resend
  if (ack.status() != Status::OK) {
    spdlog::warn("planet: server refused publish {} on '{}': {}: {}", ack.publish_id(), it->second.topic(),
                 status_name(ack.status()), ack.message());
  }
  unacked_.erase(it);
  budget_.give_back();
  if (auto waiter = awaited_.find(ack.publish_id()); waiter != awaited_.end()) {
    waiter->second = ack;
    acked_.notify_all();
  }
}

void PublishQueue::close() {
  std::lock_guard<std::mutex> lock(mutex_);
  closed_ = true;
  sink_.reset();
  if (!unacked_.empty()) {
    spdlog::warn("planet: client stopped with {} unacknowledged publishes; they are dropped", unacked_.size());
  }
  budget_.give_back(unacked_.size());
  unacked_.clear();
  acked_.notify_all();
}

size_t PublishQueue::unacknowledged() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return unacked_.size();
}

}  // namespace urs::planet::detail
