#include "urs/rtc/execution_context.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::rtc {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

PeriodicExecutionContext::PeriodicExecutionContext(Orb& orb, double rate_hz,
                                                   std::chrono::milliseconds transition_timeout)
    : orb_(orb), transition_timeout_(transition_timeout), rate_hz_(rate_hz) {
  CORBA::Object_var object = orb_.activate(this);
  self_ = RTC::ExecutionContextService::_narrow(object);
  thread_ = std::thread([this] { run(); });
}

PeriodicExecutionContext::~PeriodicExecutionContext() { shutdown(); }

RTC::ExecutionContextService_ptr PeriodicExecutionContext::reference() const {
  return RTC::ExecutionContextService::_duplicate(self_.in());
}

void PeriodicExecutionContext::bind_owner(RTC::RTObject_ptr owner) {
  auto participant = std::make_shared<Participant>();
  participant->owner = true;
  participant->ref = RTC::LightweightRTObject::_duplicate(owner);
  participant->data_flow = RTC::DataFlowComponent::_narrow(owner);
  participant->handle = 0;
  std::lock_guard lock(mutex_);
  owner_ = RTC::RTObject::_duplicate(owner);
  participants_.push_back(std::move(participant));
}

void PeriodicExecutionContext::shutdown() {
  if (is_running()) stop();
  {
    std::lock_guard lock(mutex_);
    if (stop_thread_) return;
    stop_thread_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable() && !on_own_thread()) thread_.join();
  orb_.deactivate(this);
}

// ---- the thread ----

void PeriodicExecutionContext::run() {
  std::unique_lock lock(mutex_);
  auto next = Clock::now();
  auto pending = [this] {
    return std::any_of(participants_.begin(), participants_.end(),
                       [](const ParticipantPtr& p) { return p->request != Request::kNone && !p->busy; });
  };
  while (!stop_thread_) {
    if (!running_) {
      changed_.wait(lock, [&] { return stop_thread_ || running_; });
      next = Clock::now();
      continue;
    }
    serve_requests(lock);
    if (Clock::now() >= next && running_) {
      execute(lock);
      next += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate_hz_));
      if (next < Clock::now()) next = Clock::now();  // overran: no burst to catch up
    }
    changed_.wait_until(lock, next, [&] { return stop_thread_ || !running_ || pending(); });
  }
}

void PeriodicExecutionContext::serve_requests(std::unique_lock<std::mutex>& lock) {
  const auto snapshot = participants_;
  for (const auto& p : snapshot) {
    if (p->request == Request::kNone || p->busy) continue;
    const Request request = p->request;
    p->request = Request::kNone;
    // Set before the lock is released again, so the requester never reads a stale result.
    p->request_result = make_transition(lock, *p, request);
  }
}

RTC::LifeCycleState PeriodicExecutionContext::make_transition(std::unique_lock<std::mutex>& lock, Participant& p,
                                                              Request request) {
  p.busy = true;
  lock.unlock();
  const RTC::LifeCycleState state = transition(p, request);
  lock.lock();
  p.state = state;
  p.busy = false;
  changed_.notify_all();
  return state;
}

void PeriodicExecutionContext::execute(std::unique_lock<std::mutex>& lock) {
  in_tick_ = true;
  const auto snapshot = participants_;
  for (const auto& p : snapshot) {
    if (p->busy || (p->state != RTC::ACTIVE && p->state != RTC::ERROR) || CORBA::is_nil(p->data_flow)) continue;
    p->busy = true;
    const RTC::LifeCycleState state = p->state;
    lock.unlock();
    RTC::LifeCycleState next = state;
    bool gone = false;
    try {
      if (state == RTC::ACTIVE) {
        RTC::ReturnCode_t result = p->data_flow->on_execute(p->handle);
        if (result == RTC::RTC_OK) result = p->data_flow->on_state_update(p->handle);
        if (result != RTC::RTC_OK) {
          spdlog::warn(
              "execution context: a participant returned {} from on_execute/on_state_update: "
              "it goes to the Error state",
              return_code_name(result));
          p->data_flow->on_aborting(p->handle);
          next = RTC::ERROR;
        }
      } else {
        p->data_flow->on_error(p->handle);
      }
    } catch (const CORBA::SystemException& e) {
      gone = is_gone(p->ref);
      if (!gone) {
        spdlog::warn("execution context: a participant failed during execution: {}", describe(e));
        next = RTC::ERROR;
      }
    }
    lock.lock();
    p->busy = false;
    if (gone) {
      remove_gone(p, "on_execute");
    } else if (p->request == Request::kNone || next == RTC::ERROR) {
      p->state = next;
    }
    changed_.notify_all();
  }
  in_tick_ = false;
  changed_.notify_all();
}

RTC::LifeCycleState PeriodicExecutionContext::transition(const Participant& p, Request request) {
  try {
    switch (request) {
      case Request::kActivate:
        if (p.ref->on_activated(p.handle) == RTC::RTC_OK) return RTC::ACTIVE;
        spdlog::warn("execution context: on_activated failed: the component goes to the Error state");
        return RTC::ERROR;
      case Request::kDeactivate:
        if (p.ref->on_deactivated(p.handle) == RTC::RTC_OK) return RTC::INACTIVE;
        spdlog::warn("execution context: on_deactivated failed: the component goes to the Error state");
        return RTC::ERROR;
      case Request::kReset:
        if (p.ref->on_reset(p.handle) == RTC::RTC_OK) return RTC::INACTIVE;
        spdlog::warn("execution context: on_reset failed: the component stays in the Error state");
        return RTC::ERROR;
      case Request::kNone:
        break;
    }
  } catch (const CORBA::SystemException& e) {
    spdlog::warn("execution context: a participant failed during a state transition: {}", describe(e));
    return RTC::ERROR;
  }
  return p.state;
}

void PeriodicExecutionContext::remove_gone(const ParticipantPtr& p, const char* during) {
  spdlog::warn("execution context: a participant no longer exists ({}): removed", during);
  participants_.erase(std::remove(participants_.begin(), participants_.end(), p), participants_.end());
}

PeriodicExecutionContext::ParticipantPtr PeriodicExecutionContext::find(RTC::LightweightRTObject_ptr comp) {
  if (CORBA::is_nil(comp)) return nullptr;
  for (const auto& p : participants_) {
    try {
      if (p->ref->_is_equivalent(comp)) return p;
    } catch (const CORBA::SystemException&) {
    }
  }
  return nullptr;
}

void PeriodicExecutionContext::for_each_participant(const std::function<void(const Participant&)>& call) {
  std::vector<ParticipantPtr> snapshot;
  {
    std::lock_guard lock(mutex_);
    snapshot = participants_;
  }
  for (const auto& p : snapshot) {
    try {
      call(*p);
    } catch (const CORBA::SystemException& e) {
      std::lock_guard lock(mutex_);
      if (is_gone(p->ref)) remove_gone(p, describe(e).c_str());
    }
  }
}

// ---- RTC::ExecutionContext ----

CORBA::Boolean PeriodicExecutionContext::is_running() {
  std::lock_guard lock(mutex_);
  return running_;
}

RTC::ReturnCode_t PeriodicExecutionContext::start() {
  {
    std::lock_guard lock(mutex_);
    if (running_ || stop_thread_) return RTC::PRECONDITION_NOT_MET;
  }
  for_each_participant([](const Participant& p) { p.ref->on_startup(p.handle); });
  {
    std::lock_guard lock(mutex_);
    running_ = true;
  }
  changed_.notify_all();
  return RTC::RTC_OK;
}

RTC::ReturnCode_t PeriodicExecutionContext::stop() {
  {
    std::unique_lock lock(mutex_);
    if (!running_) return RTC::PRECONDITION_NOT_MET;
    running_ = false;
    changed_.notify_all();
    // The tick in progress finishes first (unless stop() comes from inside it).
    if (!on_own_thread()) changed_.wait(lock, [&] { return !in_tick_; });
  }
  for_each_participant([](const Participant& p) { p.ref->on_shutdown(p.handle); });
  return RTC::RTC_OK;
}

CORBA::Double PeriodicExecutionContext::get_rate() {
  std::lock_guard lock(mutex_);
  return rate_hz_;
}

RTC::ReturnCode_t PeriodicExecutionContext::set_rate(CORBA::Double rate) {
  if (!(rate > 0) || !std::isfinite(rate)) return RTC::BAD_PARAMETER;
  {
    std::lock_guard lock(mutex_);
    rate_hz_ = rate;
  }
  changed_.notify_all();
  for_each_participant([](const Participant& p) {
    if (!CORBA::is_nil(p.data_flow)) p.data_flow->on_rate_changed(p.handle);
  });
  return RTC::RTC_OK;
}

RTC::ReturnCode_t PeriodicExecutionContext::add_component(RTC::LightweightRTObject_ptr comp) {
  if (CORBA::is_nil(comp)) return RTC::BAD_PARAMETER;
  {
    std::lock_guard lock(mutex_);
    if (find(comp)) return RTC::PRECONDITION_NOT_MET;
  }
  auto participant = std::make_shared<Participant>();
  try {
    participant->handle = comp->attach_context(self_.in());
    participant->data_flow = RTC::DataFlowComponent::_narrow(comp);
  } catch (const CORBA::SystemException& e) {
    spdlog::warn("execution context: add_component: the component does not answer: {}", describe(e));
    return RTC::BAD_PARAMETER;
  }
  if (participant->handle < 0) return RTC::BAD_PARAMETER;
  participant->ref = RTC::LightweightRTObject::_duplicate(comp);
  std::lock_guard lock(mutex_);
  participants_.push_back(std::move(participant));
  return RTC::RTC_OK;
}

RTC::ReturnCode_t PeriodicExecutionContext::remove_component(RTC::LightweightRTObject_ptr comp) {
  ParticipantPtr p;
  {
    std::lock_guard lock(mutex_);
    p = find(comp);
    if (!p || p->owner) return RTC::BAD_PARAMETER;
    if (p->state == RTC::ACTIVE || p->busy) return RTC::PRECONDITION_NOT_MET;
    participants_.erase(std::remove(participants_.begin(), participants_.end(), p), participants_.end());
  }
  try {
    p->ref->detach_context(p->handle);
  } catch (const CORBA::SystemException& e) {
    spdlog::debug("execution context: remove_component: detach_context failed: {}", describe(e));
  }
  return RTC::RTC_OK;
}

RTC::ReturnCode_t PeriodicExecutionContext::request_transition(RTC::LightweightRTObject_ptr comp, Request request) {
  const RTC::LifeCycleState from = request == Request::kActivate     ? RTC::INACTIVE
                                   : request == Request::kDeactivate ? RTC::ACTIVE
                                                                     : RTC::ERROR;
  const RTC::LifeCycleState to = request == Request::kActivate ? RTC::ACTIVE : RTC::INACTIVE;
  std::unique_lock lock(mutex_);
  ParticipantPtr p = find(comp);
  if (!p) return RTC::BAD_PARAMETER;
  if (p->state != from || p->request != Request::kNone) return RTC::PRECONDITION_NOT_MET;
  if (on_own_thread()) {
    // From inside one of this context's callbacks: the thread makes the transition after it.
    p->request = request;
    return RTC::RTC_OK;
  }
  if (!running_) {
    // A stopped context makes the transition in the caller's thread.
    changed_.wait(lock, [&] { return !p->busy; });
    if (p->state != from) return RTC::PRECONDITION_NOT_MET;
    return make_transition(lock, *p, request) == to ? RTC::RTC_OK : RTC::RTC_ERROR;
  }
  p->request = request;
  changed_.notify_all();
  const bool done =
      changed_.wait_for(lock, transition_timeout_, [&] { return p->request == Request::kNone && !p->busy; });
  if (!done) {
    spdlog::warn("execution context: transition not made within {} ms; it stays requested",
                 transition_timeout_.count());
    return RTC::RTC_ERROR;
  }
  // The result of this transition: by now an execution may already have moved the state on.
  return p->request_result == to ? RTC::RTC_OK : RTC::RTC_ERROR;
}

RTC::ReturnCode_t PeriodicExecutionContext::activate_component(RTC::LightweightRTObject_ptr comp) {
  return request_transition(comp, Request::kActivate);
}

RTC::ReturnCode_t PeriodicExecutionContext::deactivate_component(RTC::LightweightRTObject_ptr comp) {
  return request_transition(comp, Request::kDeactivate);
}

RTC::ReturnCode_t PeriodicExecutionContext::reset_component(RTC::LightweightRTObject_ptr comp) {
  return request_transition(comp, Request::kReset);
}

RTC::LifeCycleState PeriodicExecutionContext::get_component_state(RTC::LightweightRTObject_ptr comp) {
  std::lock_guard lock(mutex_);
  ParticipantPtr p = find(comp);
  return p ? p->state : RTC::CREATED;
}

RTC::ExecutionKind PeriodicExecutionContext::get_kind() { return RTC::PERIODIC; }

RTC::ExecutionContextProfile* PeriodicExecutionContext::get_profile() {
  std::lock_guard lock(mutex_);
  auto* profile = new RTC::ExecutionContextProfile;
  profile->kind = RTC::PERIODIC;
  profile->rate = rate_hz_;
  profile->owner = RTC::RTObject::_duplicate(owner_.in());
  CORBA::ULong n = 0;
  profile->participants.length(static_cast<CORBA::ULong>(participants_.size()));
  for (const auto& p : participants_) {
    RTC::RTObject_var rtc;
    try {
      rtc = RTC::RTObject::_narrow(p->ref.in());
    } catch (const CORBA::SystemException&) {
      continue;
    }
    if (!CORBA::is_nil(rtc)) profile->participants[n++] = rtc._retn();
  }
  profile->participants.length(n);
  nv_set(profile->properties, "type", "PeriodicExecutionContext");
  nv_set(profile->properties, "sync_transition", "YES");
  nv_set(profile->properties, "transition_timeout", std::to_string(transition_timeout_.count() / 1000.0));
  return profile;
}

}  // namespace urs::rtc
