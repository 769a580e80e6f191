#pragma once
// A side of the bridge: one middleware (RT-Middleware, CAMUS, the DDS link between spaces, an
// in-memory side in tests) as the core sees it, through the few things a side can do. Each is a
// small interface; a side implements those it can and returns null for the others:
//
//   ServiceSource    offers services (its complete list, and a change notification through
//                    SideEvents::offers_changed) and serves the calls another side's stand-ins make
//                    to one of them (an agent taking each call as a call::Request)
//   ServiceOffering  stands for another side's services (makes and withdraws stand-ins)
//   StateSource, StateSink      carry a space's state: entries and events, and its components
//   StreamSource, StreamSink    carry values of a type from one side's stream to another's
//
// The core (Bridge) knows sides by name only; which sides exist and how directions connect them is
// configuration (docs/architecture.md, "The bridge"). A side never includes another side.
//
// Threads: start(), stop(), open(), close(), poll() and the capabilities' control methods run on the
// bridge's thread; what each capability says about its other threads is in its own comment.

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "urs/agent/agent.hpp"
#include "urs/bridge/core/offer.hpp"
#include "urs/bridge/core/state.hpp"

namespace google::protobuf {
class Message;
}

namespace urs::bridge::core {

struct Route;

// What a side tells the bridge, from any thread; never blocks.
class SideEvents {
 public:
  virtual ~SideEvents() = default;
  // Its offers may have changed: the directions from it read them now instead of at their period.
  virtual void offers_changed() = 0;
  // It may have lost the stand-ins it offered (a restart, a cut after which the others forgot them):
  // the directions into it offer again everything still wanted.
  virtual void stand_ins_lost() = 0;
  // For a side whose lifecycle drives the bridge (Side::drives_activity): the bridge is active
  // (its sides open, its directions routed) while this says so.
  virtual void set_active(bool active) = 0;
  // Its session, open, will not work (a link that never came up) and only a new one may: the
  // bridge withdraws the routes into and from it, unwires its flows, closes it and opens it again.
  virtual void reopen() = 0;
};

// The services a side offers, and the calls to them.
class ServiceSource {
 public:
  virtual ~ServiceSource() = default;
  // What the stand-ins of its services are called where a type name is shown (an RTC's type):
  // "CamusService", "RemoteService".
  virtual std::string kind() const = 0;
  // Its services now, complete (keys unique); nullopt if it cannot say now (the routes stay as
  // they are). May block briefly (a registry read).
  virtual std::optional<std::vector<Offer>> offers() = 0;
  // The agent serving the calls made to a stand-in of route.offer: each goes on into this side
  // (AgentHost::dispatch hands it a call::Request). Throws urs::util::Error saying why it cannot
  // (the route is refused and tried again later). The agent may outlive the side's session: its
  // calls then answer UNAVAILABLE.
  virtual std::shared_ptr<agent::ServiceAgent> serve(const Route& route) = 0;
};

// What a target side's offering refused, and why (logged, retried).
struct OfferRefusal {
  std::string reason;
};
// The result of ServiceOffering::offer: refused is empty when the stand-in is offered.
struct OfferOutcome {
  std::vector<OfferRefusal> refused;
  bool ok() const { return refused.empty(); }
  static OfferOutcome done() { return {}; }
  static OfferOutcome refuse(std::string reason) { return {{{std::move(reason)}}}; }
};

// The capability of a side to offer services standing for another side's, and to withdraw them.
class ServiceOffering {
 public:
  virtual ~ServiceOffering() = default;
  // Offers a stand-in named route.name for route.offer, whose calls `from` serves (from.serve()).
  // A refusal (or an exception) is tried again later.
  virtual OfferOutcome offer(const Route& route, ServiceSource& from) = 0;
  // Withdraws what offer() made for `route` (only called after it succeeded; after stand_ins_lost
  // the side may no longer hold it, which is no error). Does not throw.
  virtual void withdraw(const Route& route) = 0;
  // route.offer.properties (or route.deadline_ms) changed while the route stands.
  virtual void update(const Route& route) { (void)route; }
  // The name this side can give a stand-in called `name` (e.g. an RTC instance name's characters).
  virtual std::string usable_name(const std::string& name) const { return name; }
};

// Where a space's state goes (urs/bridge/core/state.hpp): the link to the other spaces takes this
// space's; this space's context and events take the other spaces'. Called from any thread, one
// call at a time per source; must not block.
class StateSink {
 public:
  virtual ~StateSink() = default;
  // An entry set (alive) or ended (removed in its space, or its space lost).
  virtual void entry(const StateEntry& entry, bool alive) = 0;
  virtual void event(const StateEvent& event) = 0;
  // This space's components of `kind` ("rtc", "agent") as seen now, complete: the missing ended.
  virtual void components(const std::string& kind, const std::vector<ComponentState>& now) {
    (void)kind;
    (void)now;
  }
};

// A side whose state is shared: it hands what it has to `sink` (null: stop; returns once nothing
// more is handed to the previous sink). The sink outlives the sharing.
class StateSource {
 public:
  virtual ~StateSource() = default;
  virtual void share_state(StateSink* sink) = 0;
};

// Values of a stream (an RT OutPort's data, a CAMUS event topic's) written into another side's
// stream `entry` (an index into the bridge's configured streams of that pair of sides). From any
// thread; must not block for long.
class StreamSink {
 public:
  virtual ~StreamSink() = default;
  virtual void write(std::size_t entry, const google::protobuf::Message& value) = 0;
};
class StreamSource {
 public:
  virtual ~StreamSource() = default;
  // Hands each value of its stream `entry` to `sink` (null: stop; returns once nothing more is
  // handed to the previous sink).
  virtual void stream_to(StreamSink* sink) = 0;
};

// One middleware as the bridge composes it. Made by its registration (services/lib/bridge/src/
// sides.cpp), owned by the Bridge.
class Side {
 public:
  using Clock = std::chrono::steady_clock;

  explicit Side(std::string name) : name_(std::move(name)) {}
  virtual ~Side() = default;
  Side(const Side&) = delete;
  Side& operator=(const Side&) = delete;

  // As directions name it: "rt", "camus", "dds".
  const std::string& name() const { return name_; }

  // Once, when the bridge starts: what lives as long as the process (the bridge's RTC). `events`
  // outlives the side. Throws urs::util::Error if the side cannot start (the bridge does not).
  virtual void start(SideEvents& events) { (void)events; }
  // Once, when the bridge stops (after the last close()).
  virtual void stop() {}
  // True if the bridge is active only while this side says so (SideEvents::set_active).
  virtual bool drives_activity() const { return false; }

  // When the bridge becomes active: the side's session (a connection, a link). Throws
  // urs::util::Error if it cannot be had now: the bridge tries again later, the other sides work.
  virtual void open() {}
  // When the bridge becomes inactive, after every route into or from the side is withdrawn.
  virtual void close() {}
  // Housekeeping while open (a watch of a naming service, a catalog read once a lease), on the
  // bridge's thread; returns when it is due again.
  virtual Clock::time_point poll(Clock::time_point now) {
    (void)now;
    return Clock::time_point::max();
  }

  // Why the side, open, does not work yet ("" when it does): its session still connecting, say.
  // From any thread (a readiness probe's); must not block.
  virtual std::string not_ready() const { return {}; }

  // What it can do while open; null if it cannot.
  virtual ServiceSource* services() { return nullptr; }
  virtual ServiceOffering* offering() { return nullptr; }
  virtual StateSource* state_source() { return nullptr; }
  virtual StateSink* state_sink() { return nullptr; }
  virtual StreamSource* stream_source() { return nullptr; }
  virtual StreamSink* stream_sink() { return nullptr; }

 private:
  const std::string name_;
};

}  // namespace urs::bridge::core
