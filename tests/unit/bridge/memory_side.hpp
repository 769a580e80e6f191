#pragma once
// MemorySide: a side of the bridge held in memory (as Integration-Service tests its core with a
// mock middleware), registered with core::Bridge like the real sides: it offers services (its
// own, answered by a handler), stands for other sides' (stand-ins hosted on an AgentHost, called
// with call()), carries state and streams, and fails on demand. Every change notifies a condition
// variable; tests wait on it with a bounded timeout.

#include <google/protobuf/dynamic_message.h>

#include <chrono>
#include <condition_variable>
#include <functional>
#include <future>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "Diagnostic.pb.h"
#include "urs/agent/agent.hpp"
#include "urs/bridge/core/forwarding_agent.hpp"
#include "urs/bridge/core/route_reconciler.hpp"
#include "urs/bridge/core/side.hpp"
#include "urs/util/error.hpp"

namespace urs::bridge::test {

using namespace std::chrono_literals;

// The interface every service here has: URS::Diagnostic (echo, fail, ...), compiled in.
inline const google::protobuf::ServiceDescriptor& diagnostic() {
  return *URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic");
}

inline std::string echo_request(const std::string& text) {
  URS::Diagnostic_echo_Request request;
  request.set_text(text);
  return request.SerializeAsString();
}

inline std::string echoed(const call::Reply& reply) {
  URS::Diagnostic_echo_Reply parsed;
  return parsed.ParseFromString(reply.payload) ? parsed.result() : "(not an echo reply)";
}

class MemorySide : public core::Side,
                   public core::ServiceSource,
                   public core::ServiceOffering,
                   public core::StateSource,
                   public core::StateSink,
                   public core::StreamSource,
                   public core::StreamSink {
 public:
  // How one of its own services answers a call.
  using Handler = std::function<call::Reply(const call::Request&)>;

  explicit MemorySide(std::string name, bool drives = false)
      : core::Side(std::move(name)), drives_(drives), host_(2, events_sink_) {
    host_.start();
  }
  ~MemorySide() override { host_.stop(); }

  // ---- what a test does to it ----

  // A service of its own (interface URS::Diagnostic). The default handler echoes "<side>:<text>".
  void add_own(const std::string& service, Handler handler = {}, core::Offer offer = {}) {
    std::lock_guard lock(mutex_);
    offer.key = offer.name = service;
    if (offer.interface_name.empty()) offer.interface_name = "URS.Diagnostic";
    offer.source = name() + ":" + service;
    own_[service] = {std::move(offer), handler ? std::move(handler) : echo_handler()};
    changed_locked();
  }
  void remove_own(const std::string& service) {
    std::lock_guard lock(mutex_);
    own_.erase(service);
    changed_locked();
  }
  // Tells the bridge its offers changed (else it reads them at the direction's period).
  void announce_change() {
    if (events_ != nullptr) events_->offers_changed();
  }
  void lose_stand_ins() {
    {
      std::lock_guard lock(mutex_);
      for (const auto& [name, route] : stand_ins_) host_.remove(name);
      stand_ins_.clear();
    }
    if (events_ != nullptr) events_->stand_ins_lost();
  }
  void set_active(bool active) {
    if (events_ != nullptr) events_->set_active(active);
  }
  void ask_to_reopen() {
    if (events_ != nullptr) events_->reopen();
  }

  // Failures on demand.
  // Stand-in names offer() refuses from now on (none: it takes every one again).
  void refuse(std::set<std::string> names) {
    std::lock_guard lock(mutex_);
    refusing_ = std::move(names);
  }
  std::atomic<int> open_failures{0};  // open() fails this many times (util::Unavailable)
  std::atomic<bool> silent{false};    // offers() cannot say (nullopt)

  // A client of this side calling `service` (its own or a stand-in) as its middleware would.
  call::Reply call(const std::string& service, const std::string& operation, std::string payload,
                   std::chrono::milliseconds deadline = 2s) {
    call::Request request;
    request.service = service;
    request.operation = operation;
    request.payload = std::move(payload);
    request.deadline = std::chrono::steady_clock::now() + deadline;
    request.caller = {"", "client-of-" + name(), "client"};
    Handler own;
    {
      std::lock_guard lock(mutex_);
      const auto it = own_.find(service);
      if (it != own_.end()) own = it->second.handler;
    }
    if (own) return own(request);
    auto answered = std::make_shared<std::promise<call::Reply>>();
    auto future = answered->get_future();
    host_.dispatch(std::move(request),
                   call::Responder::from_callback([answered](call::Reply reply) { answered->set_value(reply); }));
    if (future.wait_for(deadline + 1s) != std::future_status::ready) {
      return call::Reply::error(call::Status::DEADLINE_EXCEEDED, "no answer in the test");
    }
    return future.get();
  }

  // Waits (bounded) until `condition` holds; every change of the side notifies.
  bool wait_for(const std::function<bool()>& condition, std::chrono::milliseconds timeout = 5s) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, timeout, condition);
  }
  // Under the side's lock (from wait_for's condition, or alone).
  bool holds(const std::string& stand_in) const { return stand_ins_.count(stand_in) > 0; }
  std::set<std::string> stand_ins() const {
    std::set<std::string> out;
    for (const auto& [name, route] : stand_ins_) out.insert(name);
    return out;
  }
  std::set<std::string> locked_stand_ins() {
    std::lock_guard lock(mutex_);
    return stand_ins();
  }
  core::Route stand_in(const std::string& name) {
    std::lock_guard lock(mutex_);
    return stand_ins_.at(name);
  }
  bool is_open() const { return open_; }
  int opened() const { return opened_; }
  int offered() const { return offered_; }
  int offer_attempts() const { return offer_attempts_; }  // under the side's lock, refusals included

  // State and streams received.
  std::vector<std::pair<core::StateEntry, bool>> entries;
  std::vector<core::StateEvent> events;
  std::map<std::string, std::vector<core::ComponentState>> component_lists;
  std::vector<std::pair<std::size_t, std::string>> written;  // (entry, echo text)
  // Hands this side's state / stream values to whatever sink the bridge wired.
  bool emit_event(const core::StateEvent& event) {
    std::lock_guard lock(mutex_);
    if (state_sink_ == nullptr) return false;
    state_sink_->event(event);
    return true;
  }
  bool emit_value(std::size_t entry, const std::string& text) {
    std::lock_guard lock(mutex_);
    if (stream_sink_ == nullptr) return false;
    URS::Diagnostic_echo_Request value;
    value.set_text(text);
    stream_sink_->write(entry, value);
    return true;
  }
  // Under the side's lock (wait_for's condition).
  bool state_wired() const { return state_sink_ != nullptr; }
  bool stream_wired() const { return stream_sink_ != nullptr; }

  // ---- core::Side ----
  void start(core::SideEvents& events) override { events_ = &events; }
  bool drives_activity() const override { return drives_; }
  void open() override {
    if (open_failures > 0) {
      --open_failures;
      throw util::Unavailable(name() + " is not reachable yet");
    }
    std::lock_guard lock(mutex_);
    open_ = true;
    ++opened_;
    changed_locked();
  }
  void close() override {
    std::lock_guard lock(mutex_);
    open_ = false;
    changed_locked();
  }
  core::ServiceSource* services() override { return this; }
  core::ServiceOffering* offering() override { return this; }
  core::StateSource* state_source() override { return this; }
  core::StateSink* state_sink() override { return this; }
  core::StreamSource* stream_source() override { return this; }
  core::StreamSink* stream_sink() override { return this; }

  // ---- core::ServiceSource ----
  std::string kind() const override { return "MemoryService"; }
  std::optional<std::vector<core::Offer>> offers() override {
    if (silent) return std::nullopt;
    std::lock_guard lock(mutex_);
    std::vector<core::Offer> out;
    for (const auto& [name, own] : own_) out.push_back(own.offer);
    for (const auto& [name, route] : stand_ins_) {  // what it offers for a bridge carries an origin
      core::Offer stand_in;
      stand_in.key = stand_in.name = name;
      stand_in.interface_name = route.offer.interface_name;
      stand_in.origin = route.offer.source;
      stand_in.source = this->name() + ":" + name;
      out.push_back(std::move(stand_in));
    }
    return out;
  }
  std::shared_ptr<agent::ServiceAgent> serve(const core::Route& route) override {
    {
      std::lock_guard lock(mutex_);
      if (own_.count(route.offer.name) == 0) throw util::NotFound(route.offer.name + " is gone from " + name());
    }
    return std::make_shared<core::ForwardingAgent>(std::make_shared<Sink>(*this), route.offer.name, diagnostic());
  }

  // ---- core::ServiceOffering ----
  core::OfferOutcome offer(const core::Route& route, core::ServiceSource& from) override {
    {
      std::lock_guard lock(mutex_);
      ++offer_attempts_;
      changed_locked();
      if (refusing_.count(route.name)) return core::OfferOutcome::refuse(route.name + " is refused by " + name());
    }
    std::shared_ptr<agent::ServiceAgent> agent = from.serve(route);
    std::lock_guard lock(mutex_);
    host_.add({route.name, agent, {}, route.deadline_ms});
    stand_ins_[route.name] = route;
    ++offered_;
    changed_locked();
    return core::OfferOutcome::done();
  }
  void withdraw(const core::Route& route) override {
    std::lock_guard lock(mutex_);
    host_.remove(route.name);
    stand_ins_.erase(route.name);
    changed_locked();
  }
  void update(const core::Route& route) override {
    std::lock_guard lock(mutex_);
    if (stand_ins_.count(route.name)) stand_ins_[route.name] = route;
    changed_locked();
  }

  // ---- state and streams ----
  void share_state(core::StateSink* sink) override {
    std::lock_guard lock(mutex_);
    state_sink_ = sink;
    changed_locked();
  }
  void entry(const core::StateEntry& entry, bool alive) override {
    std::lock_guard lock(mutex_);
    entries.emplace_back(entry, alive);
    changed_locked();
  }
  void event(const core::StateEvent& event) override {
    std::lock_guard lock(mutex_);
    events.push_back(event);
    changed_locked();
  }
  void components(const std::string& kind, const std::vector<core::ComponentState>& now) override {
    std::lock_guard lock(mutex_);
    component_lists[kind] = now;
    changed_locked();
  }
  void stream_to(core::StreamSink* sink) override {
    std::lock_guard lock(mutex_);
    stream_sink_ = sink;
    changed_locked();
  }
  void write(std::size_t entry, const google::protobuf::Message& value) override {
    URS::Diagnostic_echo_Request copy;
    copy.ParseFromString(value.SerializeAsString());
    std::lock_guard lock(mutex_);
    written.emplace_back(entry, copy.text());
    changed_locked();
  }

  // Notifies waiters; the caller holds mutex_.
  void changed_locked() { changed_.notify_all(); }

 private:
  // The calls a stand-in elsewhere forwards to one of this side's own services.
  class Sink : public core::CallSink {
   public:
    explicit Sink(MemorySide& side) : side_(side) {}
    bool start(call::Request& request, Done done) override {
      done(side_.call_own(request));
      return true;
    }
    call::Reply call(call::Request request) override { return side_.call_own(request); }
    std::string to() const override { return "side " + side_.name(); }

   private:
    MemorySide& side_;
  };

  call::Reply call_own(const call::Request& request) {
    Handler handler;
    {
      std::lock_guard lock(mutex_);
      const auto it = own_.find(request.service);
      if (it == own_.end()) {
        return call::Reply::error(call::Status::UNKNOWN_SERVICE, name() + " has no service " + request.service);
      }
      handler = it->second.handler;
    }
    return handler(request);
  }

  Handler echo_handler() const {
    return [side = name()](const call::Request& request) {
      URS::Diagnostic_echo_Request in;
      if (request.operation != "echo" || !in.ParseFromString(request.payload)) {
        return call::Reply::error(call::Status::BAD_ARGUMENTS, "not an echo");
      }
      URS::Diagnostic_echo_Reply out;
      out.set_result(side + ":" + in.text());
      return call::Reply::success(out.SerializeAsString());
    };
  }

  struct Own {
    core::Offer offer;
    Handler handler;
  };

  const bool drives_;
  core::SideEvents* events_ = nullptr;
  agent::DiscardingEventSink events_sink_;
  agent::AgentHost host_;  // the stand-ins' agents
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::string, Own> own_;
  std::map<std::string, core::Route> stand_ins_;
  std::set<std::string> refusing_;
  core::StateSink* state_sink_ = nullptr;
  core::StreamSink* stream_sink_ = nullptr;
  bool open_ = false;
  int opened_ = 0;
  int offered_ = 0;
  int offer_attempts_ = 0;
};

}  // namespace urs::bridge::test
