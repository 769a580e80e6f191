#pragma once
// Service agents (SAs) and the host that runs them.
//
// A ServiceAgent implements one interface (a Protobuf service generated from IDL). It sees parsed
// request messages and fills reply messages; it never touches the wire. An AgentHost maps
// service names to agents, decodes neutral calls (urs/call/call.hpp), validates them, runs the
// agent on a worker pool (so a slow agent never blocks another; operations an agent declares
// bounded and non-blocking run where the call arrived) and encodes the outcome. The same
// host serves agents inside urs-sam, the server-side service container of urs-camus-server and the
// bridge; each hands it the calls its middleware adapter converted. Nothing here knows Planet:
// what a CAMUS session needs (the registration of a hosted service, serving a host's agents on a
// Planet client, an EventSink over one) is urs::agent_camus (urs/agent/camus.hpp, urs/agent/client_sink.hpp).

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "urs/call/call.hpp"

namespace urs::agent {

// Where an agent publishes events (the SAM's Planet client, or the server's event bus).
class EventSink {
 public:
  virtual ~EventSink() = default;
  // Never blocks; returns !ok() with a reason if the event cannot be accepted (e.g. queue full).
  virtual call::Reply publish(const std::string& topic, const google::protobuf::Message& event) = 0;
};

// Accepts every event and drops it: for a host whose agents' events go nowhere.
class DiscardingEventSink final : public EventSink {
 public:
  call::Reply publish(const std::string&, const google::protobuf::Message&) override {
    return call::Reply::success({});
  }
};

struct CallContext {
  std::string service;                             // the service name the caller used
  call::Identity caller;                           // as the receiving adapter verified it; empty if unknown
  std::chrono::steady_clock::time_point deadline;  // after this the caller has given up
  EventSink* events = nullptr;                     // never null inside invoke()
};

// What invoke() returns. On OK the reply message has been filled.
struct Outcome {
  call::Status status = call::Status::OK;
  std::string message;
  std::shared_ptr<const google::protobuf::Message> exception;  // USER_EXCEPTION only

  static Outcome ok() { return {}; }
  static Outcome error(call::Status status, std::string message) { return {status, std::move(message), nullptr}; }
  // Raise an IDL exception (a message whose type is listed in the method's raises).
  static Outcome raise(std::shared_ptr<const google::protobuf::Message> exception, std::string message) {
    return {call::Status::USER_EXCEPTION, std::move(message), std::move(exception)};
  }
};

// The reply a host answers for `outcome`: `reply` serialized on OK; else the status and message,
// with the exception on USER_EXCEPTION (INTERNAL if the outcome carries none). For an agent that
// answers a call itself (ServiceAgent::forward) as the host would have.
call::Reply encode(const Outcome& outcome, const google::protobuf::Message& reply);
// The same for an outcome that is not OK (it fills no reply message).
call::Reply encode_failure(const Outcome& outcome);

class ServiceAgent {
 public:
  virtual ~ServiceAgent() = default;
  virtual const google::protobuf::ServiceDescriptor& interface() const = 0;
  // Runs on a worker thread and may block (ideally not past ctx.deadline), or on the receiving
  // thread for the operations runs_inline() names, which must not block. `request` is of
  // method.input_type(), `reply` an empty message of method.output_type(). Exceptions thrown
  // here become INTERNAL with the exception's text.
  virtual Outcome invoke(const google::protobuf::MethodDescriptor& method, const google::protobuf::Message& request,
                         google::protobuf::Message& reply, const CallContext& ctx) = 0;
  // Whether a call of `method` may run on the thread that received it (the adapter's I/O thread)
  // instead of being handed to a worker: only for work that never blocks and is bounded, such as
  // a computation in memory. It saves a thread hand-off per call; a slow operation run so would
  // hold up every other call of its adapter. Default: on a worker.
  virtual bool runs_inline(const google::protobuf::MethodDescriptor& /*method*/) const { return false; }
  // Agents that pass calls on without looking into them (to another space, to a CAMUS server)
  // may take a call as it came: its payload unparsed, on the thread that received it, answering
  // through `responder` (from any thread, once; a oneway call's answers nowhere) when the reply
  // comes. It must not block. Returning false leaves `request` and `responder` untouched, and the
  // host runs the call as usual (parsed, invoke() on a worker). Default: false.
  virtual bool forward(const google::protobuf::MethodDescriptor& /*method*/, call::Request& /*request*/,
                       call::Responder& /*responder*/) {
    return false;
  }
  virtual void start(EventSink& /*events*/) {}  // after registration; e.g. start a sensor thread
  virtual void stop() {}                        // before the host goes away; joins own threads
};

// Fixed pool of worker threads with a FIFO queue. stop() drains nothing: queued jobs that have not
// started are run with `cancelled = true` so that each can still answer its caller.
class WorkerPool {
 public:
  using Job = std::function<void(bool cancelled)>;
  explicit WorkerPool(unsigned threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;
  // Queues `job` whatever the queue holds (a stopped pool runs it at once, cancelled).
  void post(Job job);
  // Queues `job` unless `limit` jobs already wait (false: `job` untouched and not run). 0: no limit.
  bool try_post(Job& job, std::size_t limit);
  void stop();
  unsigned threads() const { return count_; }

 private:
  void run();
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Job> jobs_;
  bool stopping_ = false;
  unsigned count_ = 0;
  std::vector<std::thread> threads_;
};

struct HostedService {
  std::string name;  // unique service name, e.g. "robot1.diag"
  std::shared_ptr<ServiceAgent> agent;
  std::map<std::string, std::string> properties;
  uint32_t deadline_ms = 0;  // default deadline advertised to callers (0 = server's)
};

// How an AgentHost runs the calls it cannot run where they arrive.
struct HostOptions {
  unsigned workers = 16;
  // Calls waiting for a worker beyond which a call is refused with RESOURCE_EXHAUSTED, so that a
  // burst cannot grow the host's memory without bound. 0: no limit.
  std::size_t max_queued = 1024;
  // How a refusal names the limit (the setting that raises it), e.g. "queue" or "dds.queue".
  std::string limit_name = "queue";
};

class AgentHost {
 public:
  // `events` must outlive the host. `factory` makes reply/request messages: pass nullptr for the
  // generated factory (agents built from compiled IDL) or a DynamicMessageFactory's.
  AgentHost(HostOptions options, EventSink& events, google::protobuf::MessageFactory* factory = nullptr);
  // `workers` threads and the default queue limit (HostOptions).
  AgentHost(unsigned workers, EventSink& events, google::protobuf::MessageFactory* factory = nullptr);
  ~AgentHost();  // stop()

  // Control plane: throws std::invalid_argument naming the service on a duplicate name. A service
  // added after start() is started at once.
  void add(HostedService service);
  // Takes a service off the host (calls already running finish; later ones get UNKNOWN_SERVICE)
  // and stops its agent if the host was started. False if no service has that name.
  bool remove(const std::string& name);
  std::vector<HostedService> services() const;
  const HostedService* find(const std::string& name) const;

  void start();  // calls start() of every agent
  void stop();   // stops agents, then the pool (queued calls answered UNAVAILABLE)

  // Never blocks. Answers UNKNOWN_SERVICE, UNKNOWN_OPERATION, BAD_ARGUMENTS itself, and
  // RESOURCE_EXHAUSTED (naming options.limit_name and its value) when the call would wait behind
  // options.max_queued others; otherwise hands the call to the agent's forward(), or runs the
  // agent (on this thread if it runs the operation inline, else on the pool) and answers with its
  // outcome. Oneway requests get no reply (their
  // responder is left unanswered: the adapter passes one that answers nowhere).
  void dispatch(call::Request request, call::Responder responder);

 private:
  // Runs `agent` on this thread and answers with its outcome (a oneway call's answers nowhere).
  static void run(ServiceAgent& agent, const google::protobuf::MethodDescriptor& method,
                  const google::protobuf::Message& request, const google::protobuf::Message& reply_proto,
                  const CallContext& ctx, call::Responder& responder, bool oneway);

  const HostOptions options_;
  EventSink& events_;
  google::protobuf::MessageFactory* factory_;
  WorkerPool pool_;
  mutable std::mutex mutex_;
  std::map<std::string, HostedService> services_;
  bool started_ = false;
};

}  // namespace urs::agent
