#include "urs/agent/agent.hpp"

#include <spdlog/spdlog.h>

#include <stdexcept>
#include <utility>

#include "urs/util/trace.hpp"

namespace urs::agent {

namespace gp = google::protobuf;

WorkerPool::WorkerPool(unsigned threads) {
  if (threads == 0) threads = 1;
  count_ = threads;
  threads_.reserve(threads);
  for (unsigned i = 0; i < threads; ++i) threads_.emplace_back([this] { run(); });
}

WorkerPool::~WorkerPool() { stop(); }

void WorkerPool::post(Job job) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!stopping_) {
      jobs_.push_back(std::move(job));
      wake_.notify_one();
      return;
    }
  }
  job(true);  // pool stopped: let the job answer its caller
}

bool WorkerPool::try_post(Job& job, std::size_t limit) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!stopping_) {
      if (limit != 0 && jobs_.size() >= limit) return false;
      jobs_.push_back(std::move(job));
      wake_.notify_one();
      return true;
    }
  }
  job(true);  // pool stopped: let the job answer its caller
  return true;
}

void WorkerPool::stop() {
  std::deque<Job> cancelled;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_ && threads_.empty()) return;
    stopping_ = true;
    cancelled.swap(jobs_);
    wake_.notify_all();
  }
  for (auto& job : cancelled) job(true);
  for (auto& t : threads_) {
    if (t.joinable()) t.join();
  }
  threads_.clear();
}

void WorkerPool::run() {
  for (;;) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
      if (jobs_.empty()) return;  // stopping and drained
      job = std::move(jobs_.front());
      jobs_.pop_front();
    }
    job(false);
  }
}

AgentHost::AgentHost(HostOptions options, EventSink& events, gp::MessageFactory* factory)
    : options_(std::move(options)),
      events_(events),
      factory_(factory != nullptr ? factory : gp::MessageFactory::generated_factory()),
      pool_(options_.workers) {}

AgentHost::AgentHost(unsigned workers, EventSink& events, gp::MessageFactory* factory)
    : AgentHost(HostOptions{workers}, events, factory) {}

AgentHost::~AgentHost() { stop(); }

void AgentHost::add(HostedService service) {
  if (!service.agent) throw std::invalid_argument("service '" + service.name + "' has no agent");
  if (service.name.empty()) throw std::invalid_argument("a service agent needs a non-empty name");
  std::lock_guard<std::mutex> lock(mutex_);
  if (services_.count(service.name) != 0) {
    throw std::invalid_argument("service name '" + service.name + "' is used twice on this host");
  }
  auto name = service.name;
  auto agent = service.agent;
  services_.emplace(std::move(name), std::move(service));
  if (started_) agent->start(events_);  // a service added to a running host starts at once
}

bool AgentHost::remove(const std::string& name) {
  std::shared_ptr<ServiceAgent> agent;
  bool started = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = services_.find(name);
    if (it == services_.end()) return false;
    agent = std::move(it->second.agent);
    services_.erase(it);
    started = started_;
  }
  if (started) agent->stop();
  return true;
}

std::vector<HostedService> AgentHost::services() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<HostedService> out;
  out.reserve(services_.size());
  for (const auto& [name, service] : services_) out.push_back(service);
  return out;
}

const HostedService* AgentHost::find(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = services_.find(name);
  return it == services_.end() ? nullptr : &it->second;
}

void AgentHost::start() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (started_) return;
  started_ = true;
  for (auto& [name, service] : services_) service.agent->start(events_);
}

void AgentHost::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (started_) {
      for (auto& [name, service] : services_) service.agent->stop();
      started_ = false;
    }
  }
  pool_.stop();
}

using call::Reply;
using call::Status;

Reply encode(const Outcome& outcome, const gp::Message& reply) {
  if (outcome.status == Status::OK) return Reply::success(reply.SerializeAsString());
  return encode_failure(outcome);
}

Reply encode_failure(const Outcome& outcome) {
  if (outcome.status == Status::USER_EXCEPTION) {
    if (!outcome.exception) {
      return Reply::error(Status::INTERNAL, "agent raised an exception without a value: " + outcome.message);
    }
    return Reply::user_exception(outcome.exception->GetTypeName(), outcome.exception->SerializeAsString(),
                                 outcome.message);
  }
  return Reply::error(outcome.status, outcome.message);
}

void AgentHost::dispatch(call::Request request, call::Responder responder) {
  // The call's trace is current while it runs, here or on a worker: what its agent logs carries
  // the trace id, and the calls it makes send the trace on.
  std::optional<util::TraceContext> trace = util::TraceContext::parse(request.traceparent);
  if (!trace && util::current_trace() != nullptr) trace = *util::current_trace();
  const util::TraceScope scope(trace);
  const bool oneway = request.oneway;
  auto answer = [&responder, oneway](Reply reply) {
    if (!oneway) responder.reply(std::move(reply));
  };

  std::shared_ptr<ServiceAgent> agent;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = services_.find(request.service);
    if (it == services_.end()) {
      answer(Reply::error(Status::UNKNOWN_SERVICE, "no service named '" + request.service + "' on this host"));
      return;
    }
    agent = it->second.agent;
  }
  const gp::ServiceDescriptor& iface = agent->interface();
  const gp::MethodDescriptor* method = iface.FindMethodByName(request.operation);
  if (method == nullptr) {
    answer(Reply::error(Status::UNKNOWN_OPERATION,
                        "interface " + iface.full_name() + " has no operation '" + request.operation + "'"));
    return;
  }
  if (agent->forward(*method, request, responder)) return;
  const gp::Message* request_proto = factory_->GetPrototype(method->input_type());
  const gp::Message* reply_proto = factory_->GetPrototype(method->output_type());
  if (request_proto == nullptr || reply_proto == nullptr) {
    answer(Reply::error(Status::INTERNAL, "no message factory for " + method->full_name()));
    return;
  }
  std::shared_ptr<gp::Message> parsed(request_proto->New());
  if (!parsed->ParseFromString(request.payload)) {
    answer(Reply::error(Status::BAD_ARGUMENTS, "payload of " + request.service + "." + request.operation +
                                                   " is not a valid " + method->input_type()->full_name()));
    return;
  }

  auto ctx = std::make_shared<CallContext>();
  ctx->service = std::move(request.service);
  ctx->caller = std::move(request.caller);
  ctx->events = &events_;
  ctx->deadline = request.deadline;
  if (agent->runs_inline(*method)) {
    run(*agent, *method, *parsed, *reply_proto, *ctx, responder, oneway);
    return;
  }
  auto shared_responder = std::make_shared<call::Responder>(std::move(responder));
  WorkerPool::Job job = [agent, method, parsed, reply_proto, ctx, shared_responder, oneway,
                         trace = std::move(trace)](bool cancelled) {
    const util::TraceScope scope(trace);
    if (cancelled) {
      if (!oneway) {
        shared_responder->reply(
            Reply::error(Status::UNAVAILABLE, "service host is shutting down; " + ctx->service + " not called"));
      }
      return;
    }
    if (std::chrono::steady_clock::now() > ctx->deadline) {
      if (!oneway) {
        shared_responder->reply(Reply::error(Status::DEADLINE_EXCEEDED, "deadline passed before " + ctx->service + "." +
                                                                            method->name() + " could start"));
      }
      return;
    }
    run(*agent, *method, *parsed, *reply_proto, *ctx, *shared_responder, oneway);
  };
  if (pool_.try_post(job, options_.max_queued)) return;
  if (oneway) {
    spdlog::warn("{}.{}: oneway call dropped: {} calls wait for the host's {} workers ({} {})", ctx->service,
                 method->name(), options_.max_queued, pool_.threads(), options_.limit_name, options_.max_queued);
    return;
  }
  shared_responder->reply(
      Reply::error(Status::RESOURCE_EXHAUSTED,
                   ctx->service + "." + method->name() + " refused: " + std::to_string(options_.max_queued) +
                       " calls already wait for the host's " + std::to_string(pool_.threads()) + " workers (" +
                       options_.limit_name + " " + std::to_string(options_.max_queued) + "); try again later"));
}

void AgentHost::run(ServiceAgent& agent, const gp::MethodDescriptor& method, const gp::Message& request,
                    const gp::Message& reply_proto, const CallContext& ctx, call::Responder& responder, bool oneway) {
  std::unique_ptr<gp::Message> reply(reply_proto.New());
  Outcome outcome;
  try {
    outcome = agent.invoke(method, request, *reply, ctx);
  } catch (const std::exception& e) {
    spdlog::error("{}.{} threw: {}", ctx.service, method.name(), e.what());
    outcome = Outcome::error(Status::INTERNAL, ctx.service + "." + method.name() + " failed: " + e.what());
  }
  if (!oneway) responder.reply(encode(outcome, *reply));
}

}  // namespace urs::agent
