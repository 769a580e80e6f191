#pragma once
// Bridge: the core's loop. It composes sides (urs/bridge/core/side.hpp) it knows by name only, and
// runs the configured directions between them (docs/architecture.md, "The bridge"):
//
//   direction {from, to, rules, period}  the services side `from` offers stand on side `to` as
//                                        the rules say (a RouteReconciler per direction), read
//                                        again every period, or at once when `from` says they
//                                        changed; each direction has its own next-due time
//   state flow {from, to}                side `from` hands its state to side `to`
//   stream flow {from, to}               side `from` writes its streams' values into side `to`
//
// A side that drives the bridge's activity (the RT side's bridge RTC) makes it active and
// inactive; without one the bridge is active from start(). Becoming active opens every side; a
// side that cannot open yet is tried again every `open_retry` while the others work, and its
// directions and flows begin once it is open. Becoming inactive stops the flows, withdraws every
// route (last direction first) and closes the sides.
//
// Every call a stand-in takes is metered once, here (urs/bridge/core/call_meter.hpp): recorded
// per direction when the bridge is given recorders (its metrics), logged at debug level under its
// trace.
//
// Threads: one thread of its own runs everything above; the sides' events wake it from any thread.
// start() and shutdown() from one controlling thread; status() from any.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "urs/bridge/core/route_reconciler.hpp"
#include "urs/bridge/core/rules.hpp"
#include "urs/bridge/core/side.hpp"
#include "urs/call/recorder.hpp"

namespace urs::bridge::core {

struct DirectionConfig {
  std::string from;  // side names
  std::string to;
  std::vector<RouteRule> rules;  // the first that admits an offer routes it
  NameFilter names;              // and the name it gives must pass this
  std::chrono::milliseconds period{500};
  std::chrono::milliseconds retry{2000};  // a stand-in `to` refused is tried again after this
};

struct FlowConfig {
  std::string from;
  std::string to;
};

struct BridgeLayout {
  std::vector<DirectionConfig> directions;
  std::vector<FlowConfig> state;    // StateSource -> StateSink
  std::vector<FlowConfig> streams;  // StreamSource -> StreamSink
  std::chrono::milliseconds open_retry{2000};
};

struct DirectionStatus {
  std::string name;  // "rt -> camus"
  std::vector<Route> routes;
};

struct BridgeStatus {
  bool active = false;
  std::vector<std::string> open;               // the sides open now
  std::map<std::string, std::string> failing;  // sides that could not open, and why (the last failure)
  std::vector<DirectionStatus> directions;
};

class Bridge {
 public:
  using Clock = Side::Clock;
  // The recorder of the calls of one direction ("camus -> dds"), or null; called once per direction
  // by the constructor. The recorders outlive the bridge.
  using CallRecorders = std::function<call::CallRecorder*(const DirectionConfig& direction)>;

  // `name` names the bridge in logs. Throws urs::util::ConfigError (every problem, with the
  // direction or flow it is in) for a side named twice, or a direction or flow naming a side that
  // is not given or cannot do what it asks.
  Bridge(std::string name, std::vector<std::unique_ptr<Side>> sides, BridgeLayout layout,
         const CallRecorders& calls = {});
  ~Bridge();  // shutdown()
  Bridge(const Bridge&) = delete;
  Bridge& operator=(const Bridge&) = delete;

  // Starts every side (what a side throws is thrown, and nothing runs), then the bridge's thread.
  void start();
  // Makes the bridge inactive (flows stopped, routes withdrawn, sides closed), stops its thread,
  // then the sides. Idempotent.
  void shutdown();

  BridgeStatus status() const;
  // The names of its sides, in the order given. From any thread.
  std::vector<std::string> sides() const;
  // The side of that name; nullptr if none.
  Side* side(const std::string& name) const;

 private:
  struct Slot;
  struct Direction;
  struct Flow;

  void run();
  void activate(Clock::time_point now);
  void deactivate();
  void pass(Clock::time_point now);
  void try_open(Slot& slot, Clock::time_point now);
  void close_side(Slot& slot);  // what deactivate() does for one open side, its routes and flows first
  void wire(Flow& flow, bool on);
  Clock::time_point next_due() const;  // under mutex_
  void signal();
  void want_active(bool active);

  const std::string name_;
  std::vector<std::unique_ptr<Slot>> slots_;
  std::vector<std::unique_ptr<Direction>> directions_;
  std::vector<std::unique_ptr<Flow>> flows_;
  const std::chrono::milliseconds open_retry_;

  mutable std::mutex mutex_;  // guards the fields below and the directions' reconcilers
  std::condition_variable wake_;
  bool want_active_ = false;
  bool active_ = false;
  bool stopping_ = false;
  bool signalled_ = false;
  bool started_ = false;
  std::thread thread_;
};

}  // namespace urs::bridge::core
