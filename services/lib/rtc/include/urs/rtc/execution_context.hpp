#pragma once
// A periodic execution context (RTC::ExecutionContextService): one thread that, at the set rate,
// runs on_execute and on_state_update of its ACTIVE participants, on_error of those in ERROR,
// and carries out requested transitions:
//   INACTIVE --activate_component--> on_activated  --RTC_OK--> ACTIVE   (else ERROR)
//   ACTIVE --deactivate_component--> on_deactivated ---------> INACTIVE
//   ACTIVE --on_execute/on_state_update not RTC_OK--> on_aborting --> ERROR
//   ERROR --reset_component--> on_reset --RTC_OK--> INACTIVE (else stays ERROR)
// Transitions are synchronous: the caller waits (up to transition_timeout) for the thread to make
// them. A stopped context makes them in the caller's thread. Participants are called through
// their object references, so a foreign (OpenRTM-aist) component can take part too; one that no
// longer answers goes to ERROR.
//   activate/deactivate/reset of a non-participant  -> BAD_PARAMETER
//   from the wrong state                            -> PRECONDITION_NOT_MET
//   get_component_state of a non-participant        -> CREATED

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "RTC.hh"

namespace urs::rtc {

class Orb;

class PeriodicExecutionContext : public virtual POA_RTC::ExecutionContextService {
 public:
  PeriodicExecutionContext(Orb& orb, double rate_hz,
                           std::chrono::milliseconds transition_timeout = std::chrono::milliseconds(500));
  ~PeriodicExecutionContext() override;  // stops the thread; call shutdown() first for a clean exit

  RTC::ExecutionContextService_ptr reference() const;  // caller owns
  // Makes `owner` the owning component and its participant with handle 0 (INACTIVE).
  void bind_owner(RTC::RTObject_ptr owner);
  // Stops the context (on_shutdown), ends the thread and deactivates the servant. Idempotent.
  void shutdown();

  // ---- RTC::ExecutionContext ----
  CORBA::Boolean is_running() override;
  RTC::ReturnCode_t start() override;
  RTC::ReturnCode_t stop() override;
  CORBA::Double get_rate() override;
  RTC::ReturnCode_t set_rate(CORBA::Double rate) override;
  RTC::ReturnCode_t add_component(RTC::LightweightRTObject_ptr comp) override;
  RTC::ReturnCode_t remove_component(RTC::LightweightRTObject_ptr comp) override;
  RTC::ReturnCode_t activate_component(RTC::LightweightRTObject_ptr comp) override;
  RTC::ReturnCode_t deactivate_component(RTC::LightweightRTObject_ptr comp) override;
  RTC::ReturnCode_t reset_component(RTC::LightweightRTObject_ptr comp) override;
  RTC::LifeCycleState get_component_state(RTC::LightweightRTObject_ptr comp) override;
  RTC::ExecutionKind get_kind() override;
  // ---- RTC::ExecutionContextService ----
  RTC::ExecutionContextProfile* get_profile() override;

 private:
  enum class Request { kNone, kActivate, kDeactivate, kReset };
  struct Participant {
    bool owner = false;  // the owning component (added by bind_owner, handle 0)
    RTC::LightweightRTObject_var ref;
    RTC::DataFlowComponent_var data_flow;  // nil if the participant is not a data-flow component
    RTC::ExecutionContextHandle_t handle = 0;
    RTC::LifeCycleState state = RTC::INACTIVE;
    Request request = Request::kNone;
    RTC::LifeCycleState request_result = RTC::CREATED;  // the state the last request led to
    bool busy = false;                                  // a callback of this participant is running outside the lock
  };

  using ParticipantPtr = std::shared_ptr<Participant>;

  RTC::ReturnCode_t request_transition(RTC::LightweightRTObject_ptr comp, Request request);
  // Carries out `request` on `p` (lock not held during the callbacks); returns the new state.
  RTC::LifeCycleState transition(const Participant& p, Request request);
  // Called with the lock held and `p` not busy: marks `p` busy, makes the transition with the lock
  // released, then records the new state, clears busy and wakes the waiters. Returns the new state.
  RTC::LifeCycleState make_transition(std::unique_lock<std::mutex>& lock, Participant& p, Request request);
  void run();
  // Both called with the lock held; they release it around the participants' callbacks.
  void serve_requests(std::unique_lock<std::mutex>& lock);
  void execute(std::unique_lock<std::mutex>& lock);
  // Runs `call` for every participant (lock not held); a participant that no longer exists
  // is removed.
  void for_each_participant(const std::function<void(const Participant&)>& call);
  ParticipantPtr find(RTC::LightweightRTObject_ptr comp);         // lock held
  void remove_gone(const ParticipantPtr& p, const char* during);  // lock held
  bool on_own_thread() const { return std::this_thread::get_id() == thread_.get_id(); }

  Orb& orb_;
  const std::chrono::milliseconds transition_timeout_;
  RTC::ExecutionContextService_var self_;
  RTC::RTObject_var owner_;

  std::mutex mutex_;
  std::condition_variable changed_;  // state changes, requests, stop
  std::vector<ParticipantPtr> participants_;
  double rate_hz_;
  bool running_ = false;
  bool in_tick_ = false;
  bool stop_thread_ = false;
  std::thread thread_;
};

}  // namespace urs::rtc
