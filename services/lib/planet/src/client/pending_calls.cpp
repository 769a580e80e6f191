#include "client/pending_calls.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <exception>
#include <utility>

#include "urs/planet/reply.hpp"

namespace urs::planet::detail {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

PendingCalls::PendingCalls(asio::io_context& io, std::string target, milliseconds queue_timeout, QueueBudget& budget)
    : io_(io), target_(std::move(target)), queue_timeout_(queue_timeout), budget_(budget) {}

PendingCalls::~PendingCalls() = default;

bool PendingCalls::start(Request request, milliseconds deadline, ReplyHandler handler, Deferred& out, bool first) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (closed_) {
    defer_reply(out, std::move(handler), CallResult::error(Status::UNAVAILABLE, closed_message_));
    return false;
  }
  const bool connected = sink_ != nullptr;
  if (!connected && !budget_.try_take()) {
    const std::string message = budget_.full_message(false);
    if (handler) {
      defer_reply(out, std::move(handler), CallResult::error(Status::UNAVAILABLE, message));
    } else {
      spdlog::warn("planet: dropping oneway {}.{}: {}", request.service(), request.operation(), message);
    }
    return false;
  }
  const uint64_t id = next_id_++;
  request.set_call_id(id);
  Call call;
  call.label = request.service() + "." + request.operation();
  call.handler = std::move(handler);
  call.deadline = std::max(deadline, milliseconds(0));
  // Without a deadline the local timer bounds only the wait for a connection: once sent, the
  // server answers by the service's deadline (docs/planet.md, "Calls and deadlines").
  call.expires = Clock::now() + (call.deadline.count() > 0 ? call.deadline : queue_timeout_);
  const bool oneway = request.oneway();
  call.request = std::move(request);
  if (!oneway) {
    call.timer = std::make_unique<asio::steady_timer>(io_);
    call.timer->expires_at(call.expires);
    call.timer->async_wait([this, id](const std::error_code& error) {
      if (!error) on_deadline(id);
    });
  }
  auto it = calls_.emplace(id, std::move(call)).first;
  if (connected) {
    const bool may_send = restoring_ ? first : (queue_.empty() || first);
    if (may_send && send_locked(it, out) != Sent::kKept) return true;
    budget_.take();  // queued behind others while connected: the bound does not apply
  }
  queue_.push_back(id);
  return true;
}

PendingCalls::Sent PendingCalls::send_locked(std::map<uint64_t, Call>::iterator it, Deferred& out) {
  Call& call = it->second;
  Frame frame;
  Request& request = *frame.mutable_request();
  request = std::move(call.request);
  if (request.oneway() || call.deadline.count() == 0) {
    request.set_deadline_ms(0);  // the service's deadline, else the server's default
  } else {
    const auto left = std::chrono::duration_cast<milliseconds>(call.expires - Clock::now()).count();
    request.set_deadline_ms(static_cast<uint32_t>(std::max<int64_t>(1, left)));
  }
  const size_t size = frame.ByteSizeLong();
  if (size > send_limit_) {
    const std::string message = "request of " + std::to_string(size) + " bytes to " + call.label +
                                " exceeds the server's max_message_bytes " + std::to_string(send_limit_);
    spdlog::warn("planet: {}", message);
    if (call.timer) call.timer->cancel();
    defer_reply(out, std::move(call.handler), CallResult::error(Status::PAYLOAD_TOO_LARGE, message));
    calls_.erase(it);
    return Sent::kDropped;
  }
  const bool oneway = request.oneway();
  if (!sink_ || !sink_->send(std::move(frame))) {
    call.request = std::move(*frame.mutable_request());
    return Sent::kKept;
  }
  if (oneway) {
    calls_.erase(it);
  } else {
    call.sent = true;
  }
  return Sent::kOut;
}

void PendingCalls::open(std::shared_ptr<FrameSink> sink, uint64_t send_limit) {
  std::lock_guard<std::mutex> lock(mutex_);
  sink_ = std::move(sink);
  send_limit_ = send_limit;
  restoring_ = true;
}

void PendingCalls::flush(Deferred& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  restoring_ = false;
  while (!queue_.empty() && sink_) {
    auto it = calls_.find(queue_.front());
    if (it != calls_.end() && send_locked(it, out) == Sent::kKept) break;
    queue_.pop_front();
    budget_.give_back();
  }
}

void PendingCalls::detach(Deferred& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  sink_.reset();
  restoring_ = false;
  // At most once: what may have reached the server is never resent.
  for (auto it = calls_.begin(); it != calls_.end();) {
    if (!it->second.sent) {
      ++it;
      continue;
    }
    if (it->second.timer) it->second.timer->cancel();
    defer_reply(out, std::move(it->second.handler),
                CallResult::error(Status::UNAVAILABLE, "connection to server lost"));
    it = calls_.erase(it);
  }
}

void PendingCalls::on_reply(Reply&& reply, Deferred& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = calls_.find(reply.call_id());
  if (it == calls_.end() || !it->second.sent) {
    spdlog::debug("planet: ignoring reply to call {} (late or unknown)", reply.call_id());
    return;
  }
  if (it->second.timer) it->second.timer->cancel();
  defer_reply(out, std::move(it->second.handler), result_of(std::move(reply)));
  calls_.erase(it);
}

void PendingCalls::on_deadline(uint64_t id) {
  ReplyHandler handler;
  Status status = Status::DEADLINE_EXCEEDED;
  std::string message;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = calls_.find(id);
    if (it == calls_.end()) return;
    const bool server_deadline = it->second.deadline.count() == 0;
    if (server_deadline && it->second.sent) return;  // the server's answer bounds it now
    if (!it->second.sent) {
      queue_.erase(std::remove(queue_.begin(), queue_.end(), id), queue_.end());
      budget_.give_back();
    }
    handler = std::move(it->second.handler);
    if (server_deadline) {
      status = Status::UNAVAILABLE;
      message = it->second.label + " not sent: no connection to " + target_ + " within " +
                std::to_string(queue_timeout_.count()) + " ms";
    } else {
      message = "no reply from " + it->second.label + " within " + std::to_string(it->second.deadline.count()) + " ms";
    }
    calls_.erase(it);
  }
  if (!handler) return;
  try {
    handler(CallResult::error(status, message));
  } catch (const std::exception& exception) {
    spdlog::error("planet: reply handler threw: {}", exception.what());
  }
}

void PendingCalls::close(const std::string& message, Deferred& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  closed_ = true;
  closed_message_ = message;
  sink_.reset();
  for (auto& [id, call] : calls_) {
    if (call.timer) call.timer->cancel();
    defer_reply(out, std::move(call.handler), CallResult::error(Status::UNAVAILABLE, message));
  }
  calls_.clear();
  budget_.give_back(queue_.size());
  queue_.clear();
}

size_t PendingCalls::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return calls_.size();
}

}  // namespace urs::planet::detail
