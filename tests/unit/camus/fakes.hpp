#pragma once
// Test doubles for the CAMUS server's unit tests: sessions that record frames, an event sink
// that records events, an inline service container, a scriptable invoker, temp directories and a
// small test interface ("test.Navigation") built in code.

#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "urs/camus_server/clock.hpp"
#include "urs/camus_server/context_store.hpp"
#include "urs/camus_server/event_bus.hpp"
#include "urs/camus_server/registry.hpp"
#include "urs/camus_server/session_handler.hpp"
#include "urs/camus_server/task_manager.hpp"
#include "urs/camus_server/timer.hpp"
#include "urs/planet/call_adapter.hpp"

namespace urs::camus_server::test {

using namespace std::chrono_literals;

inline constexpr auto kWait = std::chrono::seconds(5);  // bound of every wait in the tests

class FakeSession final : public planet::Session {
 public:
  // `name` is both the authenticated identity and the declared peer name; `session` is the
  // resumable session (default: one of its own, numbered like the connection).
  FakeSession(uint64_t id, const std::string& name, planet::Role role = planet::SAM, uint64_t session = 0) {
    id_ = id;
    hello_.set_peer_name(name);
    hello_.set_role(role);
    hello_.set_version(1);
    identity_.name = name;
    identity_.role = role;
    identity_.session = session != 0 ? session : 1000 + id;
  }
  // The peer name it declares, when not its identity's.
  void declare_peer_name(const std::string& peer) { hello_.set_peer_name(peer); }
  uint64_t id() const override { return id_; }
  const planet::Hello& hello() const override { return hello_; }
  const planet::Identity& identity() const override { return identity_; }
  std::string remote_address() const override { return "127.0.0.1:" + std::to_string(40000 + id_); }
  bool send(planet::Frame frame) override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return false;
    frames_.push_back(std::move(frame));
    cv_.notify_all();
    return true;
  }
  void close(planet::Status status, const std::string& reason) override {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
    close_status_ = status;
    close_reason_ = reason;
    cv_.notify_all();
  }

  std::vector<planet::Frame> frames() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return frames_;
  }
  size_t count(planet::Frame::BodyCase kind) const {
    std::lock_guard<std::mutex> lock(mutex_);
    size_t n = 0;
    for (const auto& f : frames_) n += f.body_case() == kind ? 1 : 0;
    return n;
  }
  // The n-th (0-based) frame of `kind`, waiting up to kWait for it.
  std::optional<planet::Frame> wait_frame(planet::Frame::BodyCase kind, size_t n = 0) const {
    std::unique_lock<std::mutex> lock(mutex_);
    std::optional<planet::Frame> found;
    cv_.wait_for(lock, kWait, [&] {
      size_t seen = 0;
      for (const auto& f : frames_) {
        if (f.body_case() != kind) continue;
        if (seen++ == n) {
          found = f;
          return true;
        }
      }
      return false;
    });
    return found;
  }
  bool closed() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return closed_;
  }
  std::string close_reason() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return close_reason_;
  }
  void mark_closed() { close(planet::OK, "test"); }

 private:
  uint64_t id_ = 0;
  planet::Hello hello_;
  planet::Identity identity_;
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  std::vector<planet::Frame> frames_;
  bool closed_ = false;
  planet::Status close_status_ = planet::OK;
  std::string close_reason_;
};

// What a callback was handed, in order; thread-safe.
template <typename T>
class Recorded {
 public:
  void add(const T& item) {
    std::lock_guard<std::mutex> lock(mutex_);
    items_.push_back(item);
    cv_.notify_all();
  }
  // Waits (up to kWait) until `n` items are recorded; false if they are not by then.
  bool wait(size_t n) const {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, kWait, [&] { return items_.size() >= n; });
  }
  // Waits up to kWait for an item satisfying `pred`; the first such item, or nullopt.
  std::optional<T> wait_for(const std::function<bool(const T&)>& pred) const {
    std::unique_lock<std::mutex> lock(mutex_);
    std::optional<T> found;
    cv_.wait_for(lock, kWait, [&] {
      for (const auto& item : items_) {
        if (pred(item)) {
          found = item;
          return true;
        }
      }
      return false;
    });
    return found;
  }
  std::vector<T> get() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return items_;
  }

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  std::vector<T> items_;
};

struct RecordedEvent {
  std::string topic;
  std::string type;
  std::string payload;

  // The payload parsed as a Message (empty if it is not one).
  template <typename Message>
  Message as() const {
    Message message;
    message.ParseFromString(payload);
    return message;
  }
};

class RecordingSink final : public agent::EventSink {
 public:
  call::Reply publish(const std::string& topic, const google::protobuf::Message& event) override {
    events_.add({topic, event.GetTypeName(), event.SerializeAsString()});
    return call::Reply::success({});
  }
  std::vector<RecordedEvent> events() const { return events_.get(); }
  // Waits up to kWait for an event satisfying `pred`.
  std::optional<RecordedEvent> wait_for(const std::function<bool(const RecordedEvent&)>& pred) const {
    return events_.wait_for(pred);
  }

 private:
  Recorded<RecordedEvent> events_;
};

// A fresh directory named after the running test; removed at destruction.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name =
        std::string("camus-") + info->test_suite_name() + "-" + info->name() + "-" + std::to_string(::getpid());
    for (auto& c : name) {
      if (c == '/') c = '_';
    }
    const char* tmp = std::getenv("TMPDIR");
    path_ = std::filesystem::path(tmp != nullptr ? tmp : "/tmp") / name;
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// "test.Navigation": moveTo(MoveTo{x,y}) -> Empty, setSpeed(SetSpeed{speed}) -> Empty,
// getPosition(Empty) -> Pose; event message Arrived{x,y,count (int64)}.
inline std::string navigation_descriptor_set() {
  namespace gp = google::protobuf;
  gp::FileDescriptorProto file;
  file.set_name("test/navigation.proto");
  file.set_package("test");
  file.set_syntax("proto3");
  auto message = [&file](const std::string& name,
                         std::vector<std::pair<std::string, gp::FieldDescriptorProto::Type>> fields) {
    auto* m = file.add_message_type();
    m->set_name(name);
    int number = 1;
    for (const auto& [field, type] : fields) {
      auto* f = m->add_field();
      f->set_name(field);
      f->set_number(number++);
      f->set_type(type);
      f->set_label(gp::FieldDescriptorProto::LABEL_OPTIONAL);
    }
  };
  message("MoveTo", {{"x", gp::FieldDescriptorProto::TYPE_DOUBLE}, {"y", gp::FieldDescriptorProto::TYPE_DOUBLE}});
  message("SetSpeed", {{"speed", gp::FieldDescriptorProto::TYPE_DOUBLE}});
  message("Empty", {});
  message("Arrived", {{"x", gp::FieldDescriptorProto::TYPE_DOUBLE},
                      {"y", gp::FieldDescriptorProto::TYPE_DOUBLE},
                      {"count", gp::FieldDescriptorProto::TYPE_INT64}});
  auto* service = file.add_service();
  service->set_name("Navigation");
  auto method = [service](const std::string& name, const std::string& in, const std::string& out) {
    auto* m = service->add_method();
    m->set_name(name);
    m->set_input_type(".test." + in);
    m->set_output_type(".test." + out);
  };
  method("moveTo", "MoveTo", "Empty");
  method("setSpeed", "SetSpeed", "Empty");
  method("getPosition", "Empty", "Arrived");
  gp::FileDescriptorSet set;
  *set.add_file() = file;
  return set.SerializeAsString();
}

inline camus::RegisterRequest navigation_registration(const std::string& name, uint32_t deadline_ms = 0) {
  camus::RegisterRequest request;
  request.mutable_service()->set_name(name);
  request.mutable_service()->set_interface("test.Navigation");
  request.mutable_service()->set_deadline_ms(deadline_ms);
  request.set_descriptor_set(navigation_descriptor_set());
  return request;
}

// Hosts agents in-process: decodes the request with the generated factory and calls invoke()
// on the calling thread (the real server uses AgentHost's worker pool).
class InlineContainer final : public ServiceContainer {
 public:
  explicit InlineContainer(agent::EventSink& events) : events_(events) {}
  void add(const std::string& name, agent::ServiceAgent& agent) { agents_[name] = &agent; }
  bool hosts(const std::string& service) const override { return agents_.count(service) != 0; }
  void dispatch(const planet::Request& request, const Caller& caller, Completion done) override {
    namespace gp = google::protobuf;
    auto* agent = agents_.at(request.service());
    const auto* method = agent->interface().FindMethodByName(request.operation());
    if (method == nullptr) {
      done(planet::CallResult::error(planet::UNKNOWN_OPERATION, "no operation " + request.operation()));
      return;
    }
    auto* factory = gp::MessageFactory::generated_factory();
    std::unique_ptr<gp::Message> in(factory->GetPrototype(method->input_type())->New());
    std::unique_ptr<gp::Message> out(factory->GetPrototype(method->output_type())->New());
    if (!in->ParseFromString(request.payload())) {
      done(planet::CallResult::error(planet::BAD_ARGUMENTS, "bad payload"));
      return;
    }
    agent::CallContext ctx;
    ctx.service = request.service();
    ctx.caller = planet::caller_identity("", caller.identity, caller.role);
    ctx.events = &events_;
    auto outcome = agent->invoke(*method, *in, *out, ctx);
    if (outcome.status != call::Status::OK) {
      done(planet::CallResult::error(planet::to_planet(outcome.status), outcome.message));
    } else {
      done(planet::CallResult::success(out->SerializeAsString()));
    }
  }

 private:
  agent::EventSink& events_;
  std::map<std::string, agent::ServiceAgent*> agents_;
};

// Records calls and answers them through a scriptable handler (default: OK, empty payload).
class FakeInvoker final : public Invoker {
 public:
  struct Call {
    std::string caller;
    planet::Request request;
  };
  using Handler = std::function<void(const planet::Request&, std::function<void(planet::CallResult)>)>;

  void set_handler(Handler handler) {
    std::lock_guard<std::mutex> lock(mutex_);
    handler_ = std::move(handler);
  }
  void call(const std::string& caller, planet::Request request, std::function<void(planet::CallResult)> done) override {
    Handler handler;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      calls_.push_back({caller, request});
      handler = handler_;
      cv_.notify_all();
    }
    if (handler) {
      handler(request, std::move(done));
    } else {
      done(planet::CallResult::success({}));
    }
  }
  std::vector<Call> calls() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return calls_;
  }
  bool wait_calls(size_t n) const {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, kWait, [&] { return calls_.size() >= n; });
  }

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  std::vector<Call> calls_;
  Handler handler_;
};

// The server's parts the others are built on, in memory, on a manual clock and scheduler: the event
// bus (bus_sink publishes to it), the registry of space "kr" and the context store. Test fixtures
// derive from it and add the part under test.
struct ServerCore {
  ManualClock clock;
  EventBus bus{"", {}, clock};
  BusEventSink bus_sink{bus};
  Registry registry{"kr", bus_sink};
  ManualScheduler timers;
  ContextStore context{"", bus_sink, clock, timers};
};

// Collects events delivered to a bus subscription.
class EventCollector {
 public:
  DeliverFn deliver() {
    return [this](const planet::Event& event) {
      events_.add(event);
      return true;
    };
  }
  SubscribeAckFn ack() {
    return [this](const planet::SubscribeAck& ack) { acks_.add(ack); };
  }
  bool wait_events(size_t n) const { return events_.wait(n); }
  bool wait_ack() const { return acks_.wait(1); }
  std::vector<planet::Event> events() const { return events_.get(); }
  std::vector<planet::SubscribeAck> acks() const { return acks_.get(); }

 private:
  Recorded<planet::Event> events_;
  Recorded<planet::SubscribeAck> acks_;
};

}  // namespace urs::camus_server::test
