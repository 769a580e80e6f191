#pragma once
// The services this client provides (register_service): kept and registered again, ahead of
// anything queued, every time a session opens.
//
// Threading: thread-safe. Takes the PendingCalls lock under its own (never the reverse).

#include <mutex>
#include <string>
#include <vector>

#include "camus.pb.h"
#include "client/deferred.hpp"
#include "client/pending_calls.hpp"

namespace urs::planet::detail {

class Registrations {
 public:
  explicit Registrations(PendingCalls& calls);

  // Keeps `registration` (replacing one of the same service name) and registers it now if a
  // session is open, else first thing in the next one; `handler` (if any) gets the result of
  // that attempt, later re-registrations only log a failure.
  void add(const camus::RegisterRequest& registration, ReplyHandler handler, Deferred& out);
  // Forgets the service: it is not registered again (unregistering is a call of its own).
  void remove(const std::string& name);
  // Whether this client provides `name` (added and not removed).
  bool has(const std::string& name) const;

  // A session opened (PendingCalls restoring): registers every service ahead of the queue.
  void open(Deferred& out);
  void detach();
  // Handlers still waiting for a first attempt get UNAVAILABLE `message`; later add()s too.
  void close(const std::string& message, Deferred& out);

 private:
  struct Registration {
    camus::RegisterRequest request;
    ReplyHandler first_handler;  // result of the first attempt; then re-registrations only log
  };
  // With mutex_ held: starts the camus.registry Register call of `registration`; without a
  // handler a failure is logged.
  void send_locked(const camus::RegisterRequest& registration, ReplyHandler handler, bool first, Deferred& out);

  PendingCalls& calls_;
  mutable std::mutex mutex_;
  std::vector<Registration> registrations_;
  bool open_ = false;
  bool closed_ = false;
  std::string closed_message_;
};

}  // namespace urs::planet::detail
