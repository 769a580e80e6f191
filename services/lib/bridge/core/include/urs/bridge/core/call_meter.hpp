#pragma once
// Every call a stand-in takes passes here once, whatever the sides: the core serves each route's
// stand-in through a MeteredSource, whose agents (MeteredAgent) wrap the source side's. Each call
// that ends is
//   - recorded (call::CallRecorder, when the bridge has one for the direction: its metrics) under
//     the stand-in's name and the operation of its interface, with its final status and the time
//     from when the stand-in's host handed it on to its outcome;
//   - logged at debug level under the call's trace ("bridged SERVICE.OP (DIRECTION): STATUS in N
//     us"), so that one call's line is found in each bridge's log by its trace id.
// While it is handed on, the call's trace (its request's traceparent, else the thread's current
// one) is the current trace of the thread handing it on: the source side's middleware sends it on
// (a Planet request, a GIOP service context, a DDS call request).
//
// Oneway calls are handed on and not recorded (nobody learns their outcome). Calls the host refuses
// before handing them on (its queue full, the deadline passed while queued) are not seen here.
//
// Threads: as the wrapped source and agents; record() of the recorder from the threads replies
// arrive on.

#include <memory>
#include <string>

#include "urs/agent/agent.hpp"
#include "urs/bridge/core/side.hpp"
#include "urs/call/recorder.hpp"

namespace urs::bridge::core {

// A ServiceAgent that hands every call to `inner` and meters it (above). Made shared
// (std::make_shared): a forwarded call keeps its agent until it ends.
class MeteredAgent final : public agent::ServiceAgent, public std::enable_shared_from_this<MeteredAgent> {
 public:
  // `direction` names the calls in logs ("camus -> dds"); `service` is the stand-in's name;
  // `calls` (null: none) outlives the agent.
  MeteredAgent(std::shared_ptr<agent::ServiceAgent> inner, std::string direction, std::string service,
               call::CallRecorder* calls);

  const google::protobuf::ServiceDescriptor& interface() const override { return inner_->interface(); }
  agent::Outcome invoke(const google::protobuf::MethodDescriptor& method, const google::protobuf::Message& request,
                        google::protobuf::Message& reply, const agent::CallContext& ctx) override;
  bool runs_inline(const google::protobuf::MethodDescriptor& method) const override {
    return inner_->runs_inline(method);
  }
  bool forward(const google::protobuf::MethodDescriptor& method, call::Request& request,
               call::Responder& responder) override;
  void start(agent::EventSink& events) override { inner_->start(events); }
  void stop() override { inner_->stop(); }

  const std::shared_ptr<agent::ServiceAgent>& inner() const { return inner_; }

 private:
  struct Ended;  // what a call's end records and logs
  const std::shared_ptr<agent::ServiceAgent> inner_;
  const std::string direction_;
  const std::string service_;
  call::CallRecorder* const calls_;
};

// A ServiceSource whose agents are metered: the one a direction's reconciler serves its routes
// through. `source` (and `calls`, if any) outlive it.
class MeteredSource final : public ServiceSource {
 public:
  MeteredSource(ServiceSource& source, std::string direction, call::CallRecorder* calls)
      : source_(source), direction_(std::move(direction)), calls_(calls) {}

  std::string kind() const override { return source_.kind(); }
  std::optional<std::vector<Offer>> offers() override { return source_.offers(); }
  std::shared_ptr<agent::ServiceAgent> serve(const Route& route) override;

 private:
  ServiceSource& source_;
  const std::string direction_;
  call::CallRecorder* const calls_;
};

}  // namespace urs::bridge::core
