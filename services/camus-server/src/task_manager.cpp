#include "urs/camus_server/task_manager.hpp"

#include <google/protobuf/dynamic_message.h>

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/message_differencer.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "urs/camus_server/agent_util.hpp"
#include "urs/util/cli.hpp"

namespace urs::camus_server {

namespace gp = google::protobuf;
namespace fs = std::filesystem;

namespace {

constexpr const char* kRunning = "running";
constexpr const char* kSucceeded = "succeeded";
constexpr const char* kFailed = "failed";
constexpr const char* kCancelled = "cancelled";

std::string status_text(planet::Status status) { return planet::Status_Name(status); }

std::optional<uint64_t> run_number(const std::string& run_id) {
  if (run_id.size() < 2 || run_id[0] != 'r') return std::nullopt;
  uint64_t value = 0;
  for (size_t i = 1; i < run_id.size(); ++i) {
    if (run_id[i] < '0' || run_id[i] > '9' || value > (UINT64_MAX - 9) / 10) return std::nullopt;
    value = value * 10 + static_cast<uint64_t>(run_id[i] - '0');
  }
  return value;
}

std::optional<double> as_number(const gp::Value& value) {
  if (value.kind_case() == gp::Value::kNumberValue) return value.number_value();
  if (value.kind_case() == gp::Value::kStringValue) {
    const std::string& text = value.string_value();
    if (text.empty()) return std::nullopt;
    char* end = nullptr;
    double parsed = std::strtod(text.c_str(), &end);
    if (end != text.c_str() + text.size()) return std::nullopt;
    return parsed;
  }
  return std::nullopt;
}

const gp::Value* find_path(const gp::Struct& root, const std::string& path) {
  const gp::Struct* current = &root;
  const gp::Value* found = nullptr;
  size_t start = 0;
  for (;;) {
    size_t dot = path.find('.', start);
    std::string name = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    auto it = current->fields().find(name);
    if (it == current->fields().end()) return nullptr;
    found = &it->second;
    if (dot == std::string::npos) return found;
    if (found->kind_case() != gp::Value::kStructValue) return nullptr;
    current = &found->struct_value();
    start = dot + 1;
  }
}

}  // namespace

bool values_equal(const gp::Value& a, const gp::Value& b) {
  if (a.kind_case() == b.kind_case()) return gp::util::MessageDifferencer::Equals(a, b);
  auto x = as_number(a);
  auto y = as_number(b);
  return x && y && *x == *y;
}

bool event_matches(const planet::Event& event, const std::vector<std::pair<std::string, gp::Value>>& match,
                   const SchemaLookup& schemas) {
  if (match.empty()) return true;
  std::string json;
  const std::string& type = event.content_type();
  if (type == "application/json") {
    json = event.payload();
  } else if (!type.empty()) {
    auto schema = schemas.schema_with_message(type);
    const gp::Descriptor* descriptor = schema ? schema->find_message(type) : nullptr;
    if (descriptor == nullptr) return false;
    auto converted = schema->payload_to_json(*descriptor, event.payload());
    if (!converted.ok()) return false;
    json = std::move(converted.value());
  } else {
    return false;
  }
  gp::Struct payload;
  if (!gp::util::JsonStringToMessage(json, &payload).ok()) return false;
  for (const auto& [path, expected] : match) {
    const gp::Value* actual = find_path(payload, path);
    if (actual == nullptr || !values_equal(*actual, expected)) return false;
  }
  return true;
}

struct TaskManager::Run {
  uint64_t number = 0;
  std::string run_id;
  TaskSpec spec;
  std::string yaml;

  std::mutex mutex;
  std::condition_variable cv;
  camus::TaskRun state;
  uint32_t iteration = 0;
  uint64_t watch_seq = 0;   // wait_event looks at events after this seq
  bool resuming = false;    // the current step was started before a restart
  bool cancelled = false;   // cancel() has written the final state
  bool interrupted = false; // the server is stopping; the run stays "running" in the store
  bool exited = false;      // execute() has returned
  std::thread thread;

  bool stop_requested() const { return cancelled || interrupted; }
  std::string prefix() const {
    return spec.repeat > 1 ? "iteration " + std::to_string(iteration + 1) + "/" + std::to_string(spec.repeat) + ", "
                           : std::string();
  }
};

struct TaskManager::TriggerGuard {
  std::mutex mutex;
  TaskManager* self = nullptr;
};

TaskManager::TaskManager(const std::string& db_path, TaskManagerOptions options, Invoker& invoker,
                         EventSource& events, const ContextReader& context, const SchemaLookup& schemas,
                         agent::EventSink& sink, const Clock& clock)
    : options_(std::move(options)),
      invoker_(invoker),
      events_(events),
      context_(context),
      schemas_(schemas),
      sink_(sink),
      clock_(clock),
      db_(db_path, Durability::Full),
      trigger_guard_(std::make_shared<TriggerGuard>()) {
  trigger_guard_->self = this;
  db_.exec(
      "CREATE TABLE IF NOT EXISTS task_defs (name TEXT PRIMARY KEY, yaml TEXT NOT NULL);"
      "CREATE TABLE IF NOT EXISTS task_runs (number INTEGER PRIMARY KEY, task TEXT NOT NULL, yaml TEXT NOT NULL, "
      "state TEXT NOT NULL, run BLOB NOT NULL, iteration INTEGER NOT NULL, watch_seq INTEGER NOT NULL);");
}

TaskManager::~TaskManager() { stop(); }

void TaskManager::start() {
  std::vector<std::shared_ptr<Run>> resume;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (started_) return;
    started_ = true;
    {
      std::lock_guard<std::mutex> db_lock(db_mutex_);
      Statement defs(db_, "SELECT name, yaml FROM task_defs ORDER BY name");
      while (defs.step()) {
        std::string name = defs.column_text(0);
        std::string yaml = defs.column_text(1);
        auto spec = parse_task(yaml, name);
        if (!spec.ok()) {
          spdlog::error("stored task '{}' no longer parses and is ignored: {}", name, spec.message());
          continue;
        }
        definitions_[name] = Definition{yaml, spec.value()};
      }
    }
    if (!options_.tasks_dir.empty()) {
      std::vector<fs::path> files;
      std::error_code ec;
      for (const auto& entry : fs::directory_iterator(options_.tasks_dir, ec)) {
        auto ext = entry.path().extension().string();
        if (entry.is_regular_file() && (ext == ".yaml" || ext == ".yml")) files.push_back(entry.path());
      }
      if (ec) throw util::ConfigError("--tasks-dir: cannot read '" + options_.tasks_dir + "': " + ec.message());
      std::sort(files.begin(), files.end());
      for (const auto& file : files) {
        std::ifstream in(file);
        if (!in) throw util::ConfigError("--tasks-dir: cannot read '" + file.string() + "'");
        std::stringstream text;
        text << in.rdbuf();
        auto spec = parse_task(text.str(), file.stem().string());
        if (!spec.ok()) throw util::ConfigError("--tasks-dir: '" + file.string() + "': " + spec.message());
        auto defined = define_locked(spec.value(), text.str());
        if (!defined.ok()) throw util::ConfigError("--tasks-dir: '" + file.string() + "': " + defined.message());
        spdlog::info("task '{}' defined from {}", spec->name, file.string());
      }
    }
    for (const auto& [name, definition] : definitions_) arm_trigger_locked(definition.spec);

    std::lock_guard<std::mutex> db_lock(db_mutex_);
    Statement runs(db_, "SELECT number, yaml, state, run, iteration, watch_seq FROM task_runs ORDER BY number");
    while (runs.step()) {
      auto run = std::make_shared<Run>();
      run->number = static_cast<uint64_t>(runs.column_int(0));
      run->run_id = "r" + std::to_string(run->number);
      run->yaml = runs.column_text(1);
      run->state.ParseFromString(runs.column_blob(3));
      run->iteration = static_cast<uint32_t>(runs.column_int(4));
      run->watch_seq = static_cast<uint64_t>(runs.column_int(5));
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
  }
  for (auto& run : resume) {
    camus::TaskRun snapshot;
    {
      std::lock_guard<std::mutex> lock(run->mutex);
      save_locked(*run);
      snapshot = run->state;
    }
    spdlog::info("task run {} ({}) resumes at steps[{}]", run->run_id, run->state.task(), snapshot.step());
    publish(snapshot);
    std::lock_guard<std::mutex> lock(mutex_);
    launch(run);
  }
  // Runs that could not resume were marked failed above: store that too.
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& [number, run] : runs_) {
    std::lock_guard<std::mutex> run_lock(run->mutex);
    if (run->exited && run->state.state() == kFailed && run->state.message().rfind("cannot resume", 0) == 0) {
      save_locked(*run);
    }
  }
}

void TaskManager::stop() {
  {
    std::lock_guard<std::mutex> guard(trigger_guard_->mutex);
    trigger_guard_->self = nullptr;
  }
  std::vector<std::shared_ptr<Run>> active;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    for (auto& [task, handle] : triggers_) events_.unsubscribe_internal(handle);
    triggers_.clear();
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

Result<Done> TaskManager::define_locked(const TaskSpec& spec, const std::string& yaml) {
  try {
    std::lock_guard<std::mutex> db_lock(db_mutex_);
    Statement put(db_, "INSERT OR REPLACE INTO task_defs (name, yaml) VALUES (?, ?)");
    put.bind(1, spec.name).bind(2, yaml).step();
  } catch (const SqliteError& e) {
    return make_error(planet::INTERNAL, "task '" + spec.name + "' not stored: " + e.what());
  }
  definitions_[spec.name] = Definition{yaml, spec};
  if (started_) arm_trigger_locked(spec);
  return Done{};
}

Result<camus::TaskDefinition> TaskManager::define(const std::string& name, const std::string& yaml) {
  if (!name.empty()) {
    if (auto why = task_name_problem(name); !why.empty()) {
      return make_error(planet::BAD_ARGUMENTS, "task name '" + name + "' is not valid: " + why);
    }
  }
  auto spec = parse_task(yaml, name);
  if (!spec.ok()) return spec.error();
  if (!name.empty() && spec->name != name) {
    return make_error(planet::BAD_ARGUMENTS,
                      "task name '" + name + "' does not match the name '" + spec->name + "' in its YAML");
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (stopping_) return make_error(planet::UNAVAILABLE, "server is shutting down; task '" + spec->name + "' not defined");
  auto defined = define_locked(spec.value(), yaml);
  if (!defined.ok()) return defined.error();
  spdlog::info("task '{}' defined ({} steps)", spec->name, spec->steps.size());
  camus::TaskDefinition out;
  out.set_name(spec->name);
  out.set_yaml(yaml);
  return out;
}

void TaskManager::arm_trigger_locked(const TaskSpec& spec) {
  auto old = triggers_.find(spec.name);
  if (old != triggers_.end()) {
    events_.unsubscribe_internal(old->second);
    triggers_.erase(old);
  }
  if (spec.trigger.empty() || stopping_) return;
  auto guard = trigger_guard_;
  std::string task = spec.name;
  triggers_[task] = events_.subscribe_internal(spec.trigger_pattern, events_.last_seq(),
                                               [guard, task](const planet::Event& event) {
                                                 std::lock_guard<std::mutex> lock(guard->mutex);
                                                 if (guard->self != nullptr) guard->self->on_trigger(task, event);
                                                 return true;
                                               });
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
  auto run = start_run_locked(def->second.spec, def->second.yaml, "event:" + event.topic());
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

Result<std::shared_ptr<TaskManager::Run>> TaskManager::start_run_locked(TaskSpec spec, const std::string& yaml,
                                                                        const std::string& trigger) {
  if (stopping_) return make_error(planet::UNAVAILABLE, "server is shutting down; task '" + spec.name + "' not started");
  reap_locked();
  size_t running = 0;
  for (const auto& [number, run] : runs_) {
    std::lock_guard<std::mutex> run_lock(run->mutex);
    if (run->state.state() == kRunning) ++running;
  }
  if (running >= options_.max_running) {
    return make_error(planet::UNAVAILABLE, "too many task runs in progress (" + std::to_string(running) +
                                               "); cancel one or wait (limit " +
                                               std::to_string(options_.max_running) + ")");
  }
  auto run = std::make_shared<Run>();
  run->number = next_run_;
  run->run_id = "r" + std::to_string(run->number);
  run->yaml = yaml;
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
      std::lock_guard<std::mutex> db_lock(db_mutex_);
      Statement put(db_,
                    "INSERT INTO task_runs (number, task, yaml, state, run, iteration, watch_seq) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?)");
      put.bind(1, static_cast<int64_t>(run->number))
          .bind(2, run->spec.name)
          .bind(3, run->yaml)
          .bind(4, std::string(kRunning))
          .bind_blob(5, run->state.SerializeAsString())
          .bind(6, int64_t{0})
          .bind(7, static_cast<int64_t>(run->watch_seq))
          .step();
    } catch (const SqliteError& e) {
      return make_error(planet::INTERNAL, "task '" + run->spec.name + "' not started: " + e.what());
    }
  }
  ++next_run_;
  runs_[run->number] = run;
  spdlog::info("task '{}' run {} started ({})", run->spec.name, run->run_id, trigger);
  publish(run->state);
  return run;
}

void TaskManager::launch(const std::shared_ptr<Run>& run) {
  run->thread = std::thread([this, run] { execute(run); });
}

Result<camus::TaskRun> TaskManager::run(const camus::TaskRunRequest& request, const std::string& trigger) {
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
  TaskSpec spec;
  if (inline_spec) {
    spec = std::move(*inline_spec);
  } else {
    auto def = definitions_.find(request.name());
    if (def == definitions_.end()) {
      return make_error(planet::NOT_FOUND, "no task named '" + request.name() + "' (define it first, or pass its yaml)");
    }
    spec = def->second.spec;
    yaml = def->second.yaml;
  }
  auto run = start_run_locked(std::move(spec), yaml, trigger);
  if (!run.ok()) return run.error();
  camus::TaskRun snapshot;
  {
    std::lock_guard<std::mutex> run_lock(run.value()->mutex);
    snapshot = run.value()->state;
  }
  launch(run.value());
  return snapshot;
}

void TaskManager::save_locked(const Run& run) {
  try {
    std::lock_guard<std::mutex> db_lock(db_mutex_);
    Statement put(db_, "UPDATE task_runs SET state = ?, run = ?, iteration = ?, watch_seq = ? WHERE number = ?");
    put.bind(1, run.state.state())
        .bind_blob(2, run.state.SerializeAsString())
        .bind(3, static_cast<int64_t>(run.iteration))
        .bind(4, static_cast<int64_t>(run.watch_seq))
        .bind(5, static_cast<int64_t>(run.number))
        .step();
    if (run.state.state() != kRunning) {
      Statement prune(db_,
                      "DELETE FROM task_runs WHERE state != 'running' AND number NOT IN "
                      "(SELECT number FROM task_runs WHERE state != 'running' ORDER BY number DESC LIMIT ?)");
      prune.bind(1, static_cast<int64_t>(options_.keep_finished)).step();
    }
  } catch (const SqliteError& e) {
    spdlog::error("task run {} ({}): state '{}' not stored: {}", run.run_id, run.state.task(), run.state.state(),
                  e.what());
  }
}

void TaskManager::publish(const camus::TaskRun& snapshot) {
  sink_.publish("task/" + snapshot.task() + "/" + snapshot.run_id(), snapshot);
}

void TaskManager::finish(const std::shared_ptr<Run>& run, const std::string& state, const std::string& message) {
  camus::TaskRun snapshot;
  {
    std::lock_guard<std::mutex> lock(run->mutex);
    if (run->cancelled || run->state.state() != kRunning) return;
    run->state.set_state(state);
    run->state.set_message(message);
    run->state.set_finished_unix_ns(clock_.now_unix_ns());
    save_locked(*run);
    snapshot = run->state;
  }
  if (state == kFailed) {
    spdlog::warn("task '{}' run {} failed: {}", snapshot.task(), snapshot.run_id(), message);
  } else {
    spdlog::info("task '{}' run {} {}", snapshot.task(), snapshot.run_id(), state);
  }
  publish(snapshot);
  std::lock_guard<std::mutex> lock(finished_mutex_);
  finished_cv_.notify_all();
}

void TaskManager::execute(const std::shared_ptr<Run>& run) {
  const TaskSpec& spec = run->spec;
  uint32_t iteration;
  uint32_t step;
  {
    std::lock_guard<std::mutex> lock(run->mutex);
    iteration = run->iteration;
    step = run->state.step();
  }
  auto exit = [&run] {
    std::lock_guard<std::mutex> lock(run->mutex);
    run->exited = true;
  };
  for (; iteration < spec.repeat; ++iteration, step = 0) {
    for (; step < spec.steps.size(); ++step) {
      const TaskStep& current = spec.steps[step];
      camus::TaskRun snapshot;
      std::string prefix;
      {
        std::lock_guard<std::mutex> lock(run->mutex);
        if (run->stop_requested()) {
          run->exited = true;  // (exit() would lock again)
          return;
        }
        bool resumed = run->resuming;
        run->resuming = false;
        run->iteration = iteration;
        run->state.set_step(step);
        bool is_call = std::holds_alternative<CallStep>(current.action);
        // wait_event looks at events after the latest call (or the iteration's start); the
        // first iteration starts where the run did, so events right after Run are not missed.
        if (is_call || (step == 0 && iteration > 0 && !resumed)) run->watch_seq = events_.last_seq();
        prefix = run->prefix();
        run->state.set_message(prefix + "steps[" + std::to_string(step) + "]: " + current.summary());
        save_locked(*run);
        snapshot = run->state;
      }
      publish(snapshot);
      std::string failure;
      StepEnd end = run_step(run, current, failure);
      if (end == StepEnd::Stopped) return exit();
      if (end == StepEnd::Failed) {
        finish(run, kFailed,
               prefix + "steps[" + std::to_string(step) + "] (" + current.summary() + ") failed: " + failure);
        return exit();
      }
    }
  }
  std::string done = "completed " + std::to_string(spec.steps.size()) + " steps";
  if (spec.repeat > 1) done += " " + std::to_string(spec.repeat) + " times";
  finish(run, kSucceeded, done);
  exit();
}

TaskManager::StepEnd TaskManager::run_step(const std::shared_ptr<Run>& run, const TaskStep& step,
                                           std::string& failure) {
  if (const auto* call = std::get_if<CallStep>(&step.action)) return run_call(run, *call, failure);
  if (const auto* wait = std::get_if<WaitEventStep>(&step.action)) return run_wait_event(run, *wait, failure);
  if (const auto* ctx = std::get_if<WaitContextStep>(&step.action)) return run_wait_context(run, *ctx, failure);
  if (const auto* publish = std::get_if<PublishStep>(&step.action)) return run_publish(run, *publish, failure);
  return run_sleep(run, std::get<SleepStep>(step.action));
}

TaskManager::StepEnd TaskManager::run_publish(const std::shared_ptr<Run>&, const PublishStep& step,
                                              std::string& failure) {
  // The type as the space knows it now: interfaces come and go with their providers.
  auto schema = schemas_.schema_with_message(step.type);
  const gp::Descriptor* type = schema ? schema->find_message(step.type) : nullptr;
  if (type == nullptr) {
    failure = status_text(planet::NOT_FOUND) + ": no registered interface describes the type " + step.type;
    return StepEnd::Failed;
  }
  auto encoded = schema->json_to_payload(*type, step.payload_json);
  if (!encoded.ok()) {
    failure = status_text(encoded.status()) + ": payload " + step.payload_json + " does not fit: " + encoded.message();
    return StepEnd::Failed;
  }
  gp::DynamicMessageFactory factory;
  std::unique_ptr<gp::Message> event(factory.GetPrototype(type)->New());
  event->ParseFromString(encoded.value());
  const call::Reply published = sink_.publish(step.topic, *event);
  if (!published.ok()) {
    failure = std::string(call::status_name(published.status)) + ": " + published.message;
    return StepEnd::Failed;
  }
  return StepEnd::Next;
}

TaskManager::StepEnd TaskManager::run_call(const std::shared_ptr<Run>& run, const CallStep& step,
                                           std::string& failure) {
  std::string payload;
  auto schema = schemas_.schema_for_service(step.service);
  if (schema) {
    const gp::MethodDescriptor* method = schema->service().FindMethodByName(step.operation);
    if (method == nullptr) {
      failure = status_text(planet::UNKNOWN_OPERATION) + ": interface " + schema->interface_name() +
                " has no operation '" + step.operation + "'";
      return StepEnd::Failed;
    }
    auto encoded = schema->json_to_payload(*method->input_type(), step.args_json);
    if (!encoded.ok()) {
      failure = status_text(encoded.status()) + ": args " + step.args_json + " do not fit: " + encoded.message();
      return StepEnd::Failed;
    }
    payload = std::move(encoded.value());
  } else if (step.args_json != "{}") {
    failure = status_text(planet::BAD_ARGUMENTS) + ": cannot encode args: service '" + step.service +
              "' is not registered, or registered without a descriptor set";
    return StepEnd::Failed;
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
  if (!slot->done) return StepEnd::Stopped;
  if (!slot->result.ok()) {
    failure = status_text(slot->result.status) + ": " + slot->result.message;
    if (!slot->result.exception_type.empty()) failure += " (" + slot->result.exception_type + ")";
    return StepEnd::Failed;
  }
  return StepEnd::Next;
}

TaskManager::StepEnd TaskManager::run_wait_event(const std::shared_ptr<Run>& run, const WaitEventStep& step,
                                                 std::string& failure) {
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
  if (hit) return StepEnd::Next;
  if (stopped) return StepEnd::Stopped;
  failure = status_text(planet::DEADLINE_EXCEEDED) + ": no event on '" + step.pattern.text() + "'" +
            (step.match.empty() ? std::string() : " matching the given fields") + " within " +
            std::to_string(step.timeout_ms) + " ms";
  return StepEnd::Failed;
}

TaskManager::StepEnd TaskManager::run_wait_context(const std::shared_ptr<Run>& run, const WaitContextStep& step,
                                                   std::string& failure) {
  auto changes = std::make_shared<uint64_t>(0);
  auto pattern = TopicPattern::parse("context/" + step.key);
  if (!pattern.ok()) {
    failure = status_text(planet::BAD_ARGUMENTS) + ": " + pattern.message();
    return StepEnd::Failed;
  }
  uint64_t handle = events_.subscribe_internal(pattern.value(), events_.last_seq(), [run, changes](const planet::Event&) {
    std::lock_guard<std::mutex> lock(run->mutex);
    ++*changes;
    run->cv.notify_all();
    return true;
  });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(step.timeout_ms);
  StepEnd end = StepEnd::Next;
  for (;;) {
    uint64_t seen;
    {
      std::lock_guard<std::mutex> lock(run->mutex);
      seen = *changes;
    }
    auto entry = context_.get(step.key);
    bool satisfied = step.has_equals ? (entry.ok() && values_equal(entry->value(), step.equals))
                                     : (entry.ok() == step.exists);
    if (satisfied) break;
    std::unique_lock<std::mutex> lock(run->mutex);
    auto ready = [&] { return *changes != seen || run->stop_requested(); };
    bool woke = step.timeout_ms > 0 ? run->cv.wait_until(lock, deadline, ready) : (run->cv.wait(lock, ready), true);
    if (run->stop_requested()) {
      end = StepEnd::Stopped;
      break;
    }
    if (!woke) {
      std::string want = step.has_equals ? "to equal the given value" : (step.exists ? "to exist" : "to be absent");
      failure = status_text(planet::DEADLINE_EXCEEDED) + ": context entry '" + step.key + "' did not come " + want +
                " within " + std::to_string(step.timeout_ms) + " ms";
      end = StepEnd::Failed;
      break;
    }
  }
  events_.unsubscribe_internal(handle);
  return end;
}

TaskManager::StepEnd TaskManager::run_sleep(const std::shared_ptr<Run>& run, const SleepStep& step) {
  std::unique_lock<std::mutex> lock(run->mutex);
  run->cv.wait_until(lock, std::chrono::steady_clock::now() + std::chrono::milliseconds(step.ms),
                     [&] { return run->stop_requested(); });
  return run->stop_requested() ? StepEnd::Stopped : StepEnd::Next;
}

std::shared_ptr<TaskManager::Run> TaskManager::find_locked(const std::string& run_id) const {
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
    if (request.name().empty()) return make_error(planet::NOT_FOUND, "no task run '" + request.run_id() + "'");
  }
  for (auto it = runs_.rbegin(); it != runs_.rend(); ++it) {
    std::lock_guard<std::mutex> run_lock(it->second->mutex);
    if (it->second->state.task() == request.name()) return it->second->state;
  }
  if (definitions_.count(request.name()) == 0) {
    if (request.run_id() == request.name()) {
      return make_error(planet::NOT_FOUND, "no task run or task named '" + request.name() + "'");
    }
    return make_error(planet::NOT_FOUND, "no task named '" + request.name() + "'");
  }
  return make_error(planet::NOT_FOUND, "task '" + request.name() + "' has not run yet");
}

Result<camus::TaskRun> TaskManager::cancel(const std::string& run_id, const std::string& by) {
  camus::TaskRun snapshot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto run = find_locked(run_id);
    if (!run) return make_error(planet::NOT_FOUND, "no task run '" + run_id + "'");
    std::lock_guard<std::mutex> run_lock(run->mutex);
    if (run->state.state() != kRunning) return run->state;  // already over: nothing to do
    run->cancelled = true;
    uint32_t step = run->state.step();
    std::string where = step < run->spec.steps.size()
                            ? " at " + run->prefix() + "steps[" + std::to_string(step) + "] (" +
                                  run->spec.steps[step].summary() + ")"
                            : std::string();
    run->state.set_state(kCancelled);
    run->state.set_message("cancelled by " + (by.empty() ? std::string("unknown") : by) + where);
    run->state.set_finished_unix_ns(clock_.now_unix_ns());
    save_locked(*run);
    run->cv.notify_all();
    snapshot = run->state;
  }
  spdlog::info("task '{}' run {} {}", snapshot.task(), snapshot.run_id(), snapshot.message());
  publish(snapshot);
  std::lock_guard<std::mutex> lock(finished_mutex_);
  finished_cv_.notify_all();
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

const gp::ServiceDescriptor& TasksAgent::interface() const {
  return *camus::TaskRun::descriptor()->file()->FindServiceByName("Tasks");
}

agent::Outcome TasksAgent::invoke(const gp::MethodDescriptor& method, const gp::Message& request, gp::Message& reply,
                                  const agent::CallContext& ctx) {
  const std::string& op = method.name();
  auto answer = [&reply](const auto& result) {
    if (!result.ok()) return refused(result);
    fill_reply(reply, result.value());
    return agent::Outcome::ok();
  };
  if (op == "Define") {
    camus::TaskDefinition storage;
    const auto& in = message_as(request, storage);
    auto defined = manager_.define(in.name(), in.yaml());
    if (!defined.ok()) return refused(defined);
    camus::TaskDefineReply out;
    *out.mutable_task() = defined.value();
    fill_reply(reply, out);
    return agent::Outcome::ok();
  }
  if (op == "Run") {
    camus::TaskRunRequest storage;
    return answer(manager_.run(message_as(request, storage), ctx.caller.known() ? "call:" + ctx.caller.name : "call"));
  }
  if (op == "Status") {
    camus::TaskStatusRequest storage;
    return answer(manager_.status(message_as(request, storage)));
  }
  if (op == "Cancel") {
    camus::TaskCancelRequest storage;
    return answer(manager_.cancel(message_as(request, storage).run_id(), ctx.caller.name));
  }
  if (op == "List") {
    fill_reply(reply, manager_.list());
    return agent::Outcome::ok();
  }
  return agent::Outcome::error(call::Status::UNKNOWN_OPERATION, "interface urs.camus.Tasks has no operation '" + op + "'");
}

}  // namespace urs::camus_server
