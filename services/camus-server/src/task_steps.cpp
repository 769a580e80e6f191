#include "task_steps.hpp"

#include <google/protobuf/dynamic_message.h>

#include <chrono>

#include "urs/camus_server/event_match.hpp"
#include "urs/camus_server/topic_pattern.hpp"

namespace urs::camus_server::tasks {

namespace gp = google::protobuf;

namespace {
std::string status_text(planet::Status status) { return planet::Status_Name(status); }
}  // namespace

StepRunner::StepRunner(Invoker& invoker, EventSource& events, const ContextReader& context, const SchemaLookup& schemas)
    : invoker_(invoker), events_(events), context_(context), schemas_(schemas) {}

StepEnd StepRunner::run(const std::shared_ptr<Run>& run, const TaskStep& step, std::string& failure) {
  if (const auto* call_step = std::get_if<CallStep>(&step.action)) return call(run, *call_step, failure);
  if (const auto* wait = std::get_if<WaitEventStep>(&step.action)) return wait_event(run, *wait, failure);
  if (const auto* ctx = std::get_if<WaitContextStep>(&step.action)) return wait_context(run, *ctx, failure);
  if (const auto* publish_step = std::get_if<PublishStep>(&step.action)) return publish(*run, *publish_step, failure);
  return sleep(run, std::get<SleepStep>(step.action));
}

StepEnd StepRunner::publish(const Run& run, const PublishStep& step, std::string& failure) {
  // The type as the space knows it now: interfaces come and go with their providers.
  auto schema = schemas_.schema_with_message(step.type);
  const gp::Descriptor* type = schema ? schema->find_message(step.type) : nullptr;
  if (type == nullptr) {
    failure = status_text(planet::NOT_FOUND) + ": no registered interface describes the type " + step.type;
    return StepEnd::kFailed;
  }
  auto encoded = schema->json_to_payload(*type, step.payload_json);
  if (!encoded.ok()) {
    failure = status_text(encoded.status()) + ": payload " + step.payload_json + " does not fit: " + encoded.message();
    return StepEnd::kFailed;
  }
  gp::DynamicMessageFactory factory;
  std::unique_ptr<gp::Message> event(factory.GetPrototype(type)->New());
  event->ParseFromString(encoded.value());
  // As the task's owner, under a peer's rules: only the server speaks as the server.
  const call::Reply published = events_.publish_as(run.publisher(), step.topic, *event);
  if (!published.ok()) {
    failure = std::string(call::status_name(published.status)) + ": " + published.message;
    return StepEnd::kFailed;
  }
  return StepEnd::kNext;
}

StepEnd StepRunner::call(const std::shared_ptr<Run>& run, const CallStep& step, std::string& failure) {
  std::string payload;
  auto schema = schemas_.schema_for_service(step.service);
  if (schema) {
    const gp::MethodDescriptor* method = schema->service().FindMethodByName(step.operation);
    if (method == nullptr) {
      failure = status_text(planet::UNKNOWN_OPERATION) + ": interface " + schema->interface_name() +
                " has no operation " + quote_prefix(step.operation);
      return StepEnd::kFailed;
    }
    auto encoded = schema->json_to_payload(*method->input_type(), step.args_json);
    if (!encoded.ok()) {
      failure = status_text(encoded.status()) + ": args " + step.args_json + " do not fit: " + encoded.message();
      return StepEnd::kFailed;
    }
    payload = std::move(encoded.value());
  } else if (step.args_json != "{}") {
    failure = status_text(planet::BAD_ARGUMENTS) + ": cannot encode args: service '" + step.service +
              "' is not registered, or registered without a descriptor set";
    return StepEnd::kFailed;
  }

  struct Slot {
    bool done = false;
    planet::CallResult result;
  };
  auto slot = std::make_shared<Slot>();
  planet::Request request;
  request.set_service(step.service);
  request.set_operation(step.operation);
  request.set_payload(std::move(payload));
  request.set_deadline_ms(step.deadline_ms);
  invoker_.call("task:" + run->spec.name + "/" + run->run_id, std::move(request),
                [run, slot](planet::CallResult result) {
                  std::lock_guard<std::mutex> lock(run->mutex);
                  slot->done = true;
                  slot->result = std::move(result);
                  run->cv.notify_all();
                });
  std::unique_lock<std::mutex> lock(run->mutex);
  run->cv.wait(lock, [&] { return slot->done || run->stop_requested(); });
  if (!slot->done) return StepEnd::kStopped;
  if (!slot->result.ok()) {
    failure = status_text(slot->result.status) + ": " + slot->result.message;
    if (!slot->result.exception_type.empty()) failure += " (" + slot->result.exception_type + ")";
    return StepEnd::kFailed;
  }
  return StepEnd::kNext;
}

StepEnd StepRunner::wait_event(const std::shared_ptr<Run>& run, const WaitEventStep& step, std::string& failure) {
  struct Slot {
    bool hit = false;
    uint64_t seq = 0;
  };
  auto slot = std::make_shared<Slot>();
  uint64_t from;
  {
    std::lock_guard<std::mutex> lock(run->mutex);
    from = run->watch_seq;
  }
  auto match = step.match;
  const SchemaLookup* schemas = &schemas_;
  uint64_t handle = events_.subscribe_internal(step.pattern, from, [run, slot, match, schemas](const planet::Event& e) {
    if (!event_matches(e, match, *schemas)) return true;
    std::lock_guard<std::mutex> lock(run->mutex);
    if (!slot->hit) {
      slot->hit = true;
      slot->seq = e.seq();
    }
    run->cv.notify_all();
    return false;  // one event is enough
  });
  std::unique_lock<std::mutex> lock(run->mutex);
  auto ready = [&] { return slot->hit || run->stop_requested(); };
  if (step.timeout_ms > 0) {
    run->cv.wait_until(lock, std::chrono::steady_clock::now() + std::chrono::milliseconds(step.timeout_ms), ready);
  } else {
    run->cv.wait(lock, ready);
  }
  bool hit = slot->hit;
  if (hit) run->watch_seq = slot->seq;
  bool stopped = run->stop_requested();
  lock.unlock();
  events_.unsubscribe_internal(handle);
  if (hit) return StepEnd::kNext;
  if (stopped) return StepEnd::kStopped;
  failure = status_text(planet::DEADLINE_EXCEEDED) + ": no event on '" + step.pattern.text() + "'" +
            (step.match.empty() ? std::string() : " matching the given fields") + " within " +
            std::to_string(step.timeout_ms) + " ms";
  return StepEnd::kFailed;
}

StepEnd StepRunner::wait_context(const std::shared_ptr<Run>& run, const WaitContextStep& step, std::string& failure) {
  auto changes = std::make_shared<uint64_t>(0);
  auto pattern = TopicPattern::parse("context/" + step.key);
  if (!pattern.ok()) {
    failure = status_text(planet::BAD_ARGUMENTS) + ": " + pattern.message();
    return StepEnd::kFailed;
  }
  uint64_t handle =
      events_.subscribe_internal(pattern.value(), events_.last_seq(), [run, changes](const planet::Event&) {
        std::lock_guard<std::mutex> lock(run->mutex);
        ++*changes;
        run->cv.notify_all();
        return true;
      });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(step.timeout_ms);
  StepEnd end = StepEnd::kNext;
  for (;;) {
    uint64_t seen;
    {
      std::lock_guard<std::mutex> lock(run->mutex);
      seen = *changes;
    }
    auto entry = context_.get(step.key);
    bool satisfied =
        step.has_equals ? (entry.ok() && values_equal(entry->value(), step.equals)) : (entry.ok() == step.exists);
    if (satisfied) break;
    std::unique_lock<std::mutex> lock(run->mutex);
    auto ready = [&] { return *changes != seen || run->stop_requested(); };
    bool woke = step.timeout_ms > 0 ? run->cv.wait_until(lock, deadline, ready) : (run->cv.wait(lock, ready), true);
    if (run->stop_requested()) {
      end = StepEnd::kStopped;
      break;
    }
    if (!woke) {
      std::string want = step.has_equals ? "to equal the given value" : (step.exists ? "to exist" : "to be absent");
      failure = status_text(planet::DEADLINE_EXCEEDED) + ": context entry " + quote_prefix(step.key) +
                " did not come " + want + " within " + std::to_string(step.timeout_ms) + " ms";
      end = StepEnd::kFailed;
      break;
    }
  }
  events_.unsubscribe_internal(handle);
  return end;
}

StepEnd StepRunner::sleep(const std::shared_ptr<Run>& run, const SleepStep& step) {
  std::unique_lock<std::mutex> lock(run->mutex);
  run->cv.wait_until(lock, std::chrono::steady_clock::now() + std::chrono::milliseconds(step.ms),
                     [&] { return run->stop_requested(); });
  return run->stop_requested() ? StepEnd::kStopped : StepEnd::kNext;
}

}  // namespace urs::camus_server::tasks
