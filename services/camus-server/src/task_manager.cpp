#include "urs/camus_server/task_manager.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <optional>
#include <thread>

#include "task_files.hpp"
#include "task_run.hpp"
#include "task_runner.hpp"
#include "task_steps.hpp"
#include "task_store.hpp"
#include "task_triggers.hpp"
#include "urs/camus_server/topic_pattern.hpp"
#include "urs/util/cli.hpp"

namespace urs::camus_server {

using tasks::kCancelled;
using tasks::kFailed;
using tasks::kRunning;
using tasks::Run;

namespace {

std::optional<uint64_t> run_number(const std::string& run_id) {
  if (run_id.size() < 2 || run_id[0] != 'r') return std::nullopt;
  uint64_t value = 0;
  for (size_t i = 1; i < run_id.size(); ++i) {
    if (run_id[i] < '0' || run_id[i] > '9' || value > (UINT64_MAX - 9) / 10) return std::nullopt;
    value = value * 10 + static_cast<uint64_t>(run_id[i] - '0');
  }
  return value;
}

}  // namespace

TaskManager::TaskManager(const std::string& db_path, TaskManagerOptions options, Invoker& invoker, EventSource& events,
                         const ContextReader& context, const SchemaLookup& schemas, agent::EventSink& sink,
                         const Clock& clock)
    : options_(std::move(options)),
      events_(events),
      sink_(sink),
      clock_(clock),
      store_(std::make_unique<tasks::TaskStore>(db_path, options_.keep_finished)),
      steps_(std::make_unique<tasks::StepRunner>(invoker, events, context, schemas)),
      driver_(std::make_unique<tasks::RunDriver>(*store_, *steps_, events, sink, clock, [this] { notify_finished(); })),
      triggers_(std::make_unique<tasks::TaskTriggers>(
          events, [this](const std::string& task, const planet::Event& event) { on_trigger(task, event); })) {}

TaskManager::~TaskManager() { stop(); }

void TaskManager::notify_finished() {
  std::lock_guard<std::mutex> lock(finished_mutex_);
  finished_cv_.notify_all();
}

void TaskManager::start() {
  std::vector<std::shared_ptr<Run>> resume;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (started_) return;
    started_ = true;
    for (auto& stored : store_->definitions()) {
      auto spec = parse_task(stored.yaml, stored.name);
      if (!spec.ok()) {
        spdlog::error("stored task '{}' no longer parses and is ignored: {}", stored.name, spec.message());
        continue;
      }
      definitions_[stored.name] = Definition{stored.yaml, spec.value(), stored.owner};
    }
    if (!options_.tasks_dir.empty()) {
      for (const auto& file : tasks::read_task_dir(options_.tasks_dir)) {
        // Owned by the file: a name with '/', which no credential can have.
        const std::string owner = "tasks-dir/" + std::filesystem::path(file.path).filename().string();
        auto defined = define_locked(file.spec, file.yaml, owner);
        if (!defined.ok()) throw util::ConfigError("--tasks-dir: '" + file.path + "': " + defined.message());
        spdlog::info("task '{}' defined from {}", file.spec.name, file.path);
      }
    }
    for (const auto& [name, definition] : definitions_) triggers_->arm(definition.spec);
    resume = load_runs_locked();
  }
  for (auto& run : resume) {
    camus::TaskRun snapshot;
    {
      std::lock_guard<std::mutex> lock(run->mutex);
      store_->save(*run);
      snapshot = run->state;
    }
    spdlog::info("task run {} ({}) resumes at steps[{}]", run->run_id, run->state.task(), snapshot.step());
    tasks::publish_progress(sink_, snapshot);
    std::lock_guard<std::mutex> lock(mutex_);
    launch(run);
  }
  // Runs that could not resume were marked failed by load_runs_locked(): store that too.
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& [number, run] : runs_) {
    std::lock_guard<std::mutex> run_lock(run->mutex);
    if (run->exited && run->state.state() == kFailed && run->state.message().rfind("cannot resume", 0) == 0) {
      store_->save(*run);
    }
  }
}

std::vector<std::shared_ptr<Run>> TaskManager::load_runs_locked() {
  std::vector<std::shared_ptr<Run>> resume;
  for (auto& stored : store_->runs()) {
    auto run = std::make_shared<Run>();
    run->number = stored.number;
    run->run_id = "r" + std::to_string(run->number);
    run->yaml = std::move(stored.yaml);
    run->owner = std::move(stored.owner);
    run->state = std::move(stored.state);
    run->iteration = stored.iteration;
    run->watch_seq = stored.watch_seq;
    run->exited = true;
    next_run_ = std::max(next_run_, run->number + 1);
    if (run->state.state() == kRunning) {
      auto spec = parse_task(run->yaml, run->state.task());
      if (!spec.ok() || run->state.step() >= spec->steps.size()) {
        run->state.set_state(kFailed);
        run->state.set_message("cannot resume after restart: " +
                               (spec.ok() ? std::string("step index out of range") : spec.message()));
        run->state.set_finished_unix_ns(clock_.now_unix_ns());
      } else {
        run->spec = std::move(spec.value());
        run->resuming = true;
        run->exited = false;
        run->state.set_message(run->prefix() + "resumed after a server restart at steps[" +
                               std::to_string(run->state.step()) + "] (" +
                               run->spec.steps[run->state.step()].summary() + ")");
        resume.push_back(run);
      }
    }
    runs_[run->number] = run;
  }
  return resume;
}

void TaskManager::stop() {
  triggers_->disarm_all();
  std::vector<std::shared_ptr<Run>> active;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    for (auto& [number, run] : runs_) {
      if (run->thread.joinable()) active.push_back(run);
    }
  }
  for (auto& run : active) {
    std::lock_guard<std::mutex> lock(run->mutex);
    run->interrupted = true;
    run->cv.notify_all();
  }
  for (auto& run : active) run->thread.join();
}

Result<Done> TaskManager::define_locked(const TaskSpec& spec, const std::string& yaml, const std::string& owner) {
  try {
    store_->put_definition(spec.name, yaml, owner);
  } catch (const SqliteError& e) {
    return make_error(planet::INTERNAL, "task '" + spec.name + "' not stored: " + e.what());
  }
  definitions_[spec.name] = Definition{yaml, spec, owner};
  if (started_ && !stopping_) triggers_->arm(spec);
  return Done{};
}

Result<camus::TaskDefinition> TaskManager::define(const std::string& name, const std::string& yaml,
                                                  const std::string& owner) {
  if (!name.empty()) {
    if (auto why = task_name_problem(name); !why.empty()) {
      return make_error(planet::BAD_ARGUMENTS, "task name " + quote_prefix(name) + " is not valid: " + why);
    }
  }
  auto spec = parse_task(yaml, name);
  if (!spec.ok()) return spec.error();
  if (!name.empty() && spec->name != name) {
    return make_error(planet::BAD_ARGUMENTS, "task name " + quote_prefix(name) + " does not match the name " +
                                                 quote_prefix(spec->name) + " in its YAML");
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (stopping_)
    return make_error(planet::UNAVAILABLE, "server is shutting down; task '" + spec->name + "' not defined");
  auto defined = define_locked(spec.value(), yaml, owner);
  if (!defined.ok()) return defined.error();
  spdlog::info("task '{}' defined by {} ({} steps)", spec->name, owner.empty() ? "?" : owner, spec->steps.size());
  camus::TaskDefinition out;
  out.set_name(spec->name);
  out.set_yaml(yaml);
  return out;
}

void TaskManager::on_trigger(const std::string& task, const planet::Event& event) {
  if (event.topic().rfind("task/" + task + "/", 0) == 0) return;  // its own progress
  std::lock_guard<std::mutex> lock(mutex_);
  if (stopping_) return;
  auto def = definitions_.find(task);
  if (def == definitions_.end() || def->second.spec.trigger.empty()) return;
  for (const auto& [number, run] : runs_) {
    std::lock_guard<std::mutex> run_lock(run->mutex);
    if (run->state.task() == task && run->state.state() == kRunning) {
      spdlog::info("event {} (seq {}) does not start task '{}': run {} is still in progress", event.topic(),
                   event.seq(), task, run->run_id);
      return;
    }
  }
  auto run = start_run_locked(def->second.spec, def->second.yaml, "event:" + event.topic(), def->second.owner);
  if (!run.ok()) {
    spdlog::warn("event {} could not start task '{}': {}", event.topic(), task, run.message());
    return;
  }
  launch(run.value());
}

void TaskManager::reap_locked() {
  size_t finished = 0;
  for (auto& [number, run] : runs_) {
    bool exited;
    {
      std::lock_guard<std::mutex> run_lock(run->mutex);
      exited = run->exited;
      if (run->state.state() != kRunning) ++finished;
    }
    if (exited && run->thread.joinable()) run->thread.join();
  }
  for (auto it = runs_.begin(); it != runs_.end() && finished > options_.keep_finished;) {
    bool drop;
    {
      std::lock_guard<std::mutex> run_lock(it->second->mutex);
      drop = it->second->state.state() != kRunning && !it->second->thread.joinable();
    }
    if (drop) {
      it = runs_.erase(it);
      --finished;
    } else {
      ++it;
    }
  }
}

Result<std::shared_ptr<Run>> TaskManager::start_run_locked(TaskSpec spec, const std::string& yaml,
                                                           const std::string& trigger, const std::string& owner) {
  if (stopping_)
    return make_error(planet::UNAVAILABLE, "server is shutting down; task '" + spec.name + "' not started");
  reap_locked();
  size_t running = 0;
  for (const auto& [number, run] : runs_) {
    std::lock_guard<std::mutex> run_lock(run->mutex);
    if (run->state.state() == kRunning) ++running;
  }
  if (running >= options_.max_running) {
    return make_error(planet::UNAVAILABLE, "too many task runs in progress (" + std::to_string(running) +
                                               "); cancel one or wait (limit " + std::to_string(options_.max_running) +
                                               ")");
  }
  auto run = std::make_shared<Run>();
  run->number = next_run_;
  run->run_id = "r" + std::to_string(run->number);
  run->yaml = yaml;
  run->owner = owner;
  run->spec = std::move(spec);
  run->watch_seq = events_.last_seq();
  run->state.set_run_id(run->run_id);
  run->state.set_task(run->spec.name);
  run->state.set_state(kRunning);
  run->state.set_step(0);
  run->state.set_steps(static_cast<uint32_t>(run->spec.steps.size()));
  run->state.set_message("starting");
  run->state.set_started_unix_ns(clock_.now_unix_ns());
  run->state.set_trigger(trigger);
  {
    std::lock_guard<std::mutex> run_lock(run->mutex);
    try {
      store_->insert_run(*run);
    } catch (const SqliteError& e) {
      return make_error(planet::INTERNAL, "task '" + run->spec.name + "' not started: " + e.what());
    }
  }
  ++next_run_;
  runs_[run->number] = run;
  spdlog::info("task '{}' run {} started ({})", run->spec.name, run->run_id, trigger);
  tasks::publish_progress(sink_, run->state);
  return run;
}

void TaskManager::launch(const std::shared_ptr<Run>& run) {
  run->thread = std::thread([driver = driver_.get(), run] { driver->execute(run); });
}

Result<camus::TaskRun> TaskManager::run(const camus::TaskRunRequest& request, const std::string& trigger,
                                        const std::string& caller) {
  if (!request.name().empty() && !request.yaml().empty()) {
    return make_error(planet::BAD_ARGUMENTS, "Run takes a task name or an inline yaml, not both");
  }
  std::optional<TaskSpec> inline_spec;
  if (request.name().empty()) {
    if (request.yaml().empty()) return make_error(planet::BAD_ARGUMENTS, "Run needs a task name or an inline yaml");
    auto spec = parse_task(request.yaml(), "inline");
    if (!spec.ok()) return spec.error();
    inline_spec = std::move(spec.value());
    inline_spec->trigger.clear();  // an inline run is started once, by this call
  }
  std::lock_guard<std::mutex> lock(mutex_);
  std::string yaml = request.yaml();
  std::string owner = caller;
  TaskSpec spec;
  if (inline_spec) {
    spec = std::move(*inline_spec);
  } else {
    auto def = definitions_.find(request.name());
    if (def == definitions_.end()) {
      return make_error(planet::NOT_FOUND,
                        "no task named " + quote_prefix(request.name()) + " (define it first, or pass its yaml)");
    }
    spec = def->second.spec;
    yaml = def->second.yaml;
    owner = def->second.owner;
  }
  auto run = start_run_locked(std::move(spec), yaml, trigger, owner);
  if (!run.ok()) return run.error();
  camus::TaskRun snapshot;
  {
    std::lock_guard<std::mutex> run_lock(run.value()->mutex);
    snapshot = run.value()->state;
  }
  launch(run.value());
  return snapshot;
}

std::shared_ptr<Run> TaskManager::find_locked(const std::string& run_id) const {
  auto number = run_number(run_id);
  if (!number) return nullptr;
  auto it = runs_.find(*number);
  return it == runs_.end() ? nullptr : it->second;
}

Result<camus::TaskRun> TaskManager::status(const camus::TaskStatusRequest& request) const {
  // A run id, else the latest run of a task name; a caller that cannot tell which it holds may
  // send the same text as both.
  std::lock_guard<std::mutex> lock(mutex_);
  if (request.run_id().empty() && request.name().empty()) {
    return make_error(planet::BAD_ARGUMENTS, "Status needs a run_id or a task name");
  }
  if (!request.run_id().empty()) {
    if (auto run = find_locked(request.run_id())) {
      std::lock_guard<std::mutex> run_lock(run->mutex);
      return run->state;
    }
    if (request.name().empty()) return make_error(planet::NOT_FOUND, "no task run " + quote_prefix(request.run_id()));
  }
  for (auto it = runs_.rbegin(); it != runs_.rend(); ++it) {
    std::lock_guard<std::mutex> run_lock(it->second->mutex);
    if (it->second->state.task() == request.name()) return it->second->state;
  }
  if (definitions_.count(request.name()) == 0) {
    if (request.run_id() == request.name()) {
      return make_error(planet::NOT_FOUND, "no task run or task named " + quote_prefix(request.name()));
    }
    return make_error(planet::NOT_FOUND, "no task named " + quote_prefix(request.name()));
  }
  return make_error(planet::NOT_FOUND, "task " + quote_prefix(request.name()) + " has not run yet");
}

Result<camus::TaskRun> TaskManager::cancel(const std::string& run_id, const std::string& by) {
  camus::TaskRun snapshot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto run = find_locked(run_id);
    if (!run) return make_error(planet::NOT_FOUND, "no task run " + quote_prefix(run_id));
    std::lock_guard<std::mutex> run_lock(run->mutex);
    if (run->state.state() != kRunning) return run->state;  // already over: nothing to do
    run->cancelled = true;
    uint32_t step = run->state.step();
    std::string where = step < run->spec.steps.size() ? " at " + run->prefix() + "steps[" + std::to_string(step) +
                                                            "] (" + run->spec.steps[step].summary() + ")"
                                                      : std::string();
    run->state.set_state(kCancelled);
    run->state.set_message("cancelled by " + (by.empty() ? std::string("unknown") : by) + where);
    run->state.set_finished_unix_ns(clock_.now_unix_ns());
    store_->save(*run);
    run->cv.notify_all();
    snapshot = run->state;
  }
  spdlog::info("task '{}' run {} {}", snapshot.task(), snapshot.run_id(), snapshot.message());
  tasks::publish_progress(sink_, snapshot);
  notify_finished();
  return snapshot;
}

camus::TaskListReply TaskManager::list() const {
  camus::TaskListReply reply;
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [name, def] : definitions_) {
    auto* task = reply.add_tasks();
    task->set_name(name);
    task->set_yaml(def.yaml);
  }
  size_t finished = 0;
  for (auto it = runs_.rbegin(); it != runs_.rend(); ++it) {
    std::lock_guard<std::mutex> run_lock(it->second->mutex);
    bool running = it->second->state.state() == kRunning;
    if (!running && finished >= 100) continue;
    if (!running) ++finished;
    *reply.add_runs() = it->second->state;
  }
  return reply;
}

Result<camus::TaskRun> TaskManager::wait_finished(const std::string& run_id, std::chrono::milliseconds timeout) const {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::unique_lock<std::mutex> lock(finished_mutex_);
  for (;;) {
    camus::TaskStatusRequest request;
    request.set_run_id(run_id);
    auto state = status(request);
    if (!state.ok() || state->state() != kRunning) return state;
    if (finished_cv_.wait_until(lock, deadline) == std::cv_status::timeout) return status(request);
  }
}

}  // namespace urs::camus_server
