#pragma once
// Telling the service manager how a program is doing: the sd_notify(3) protocol, one datagram of
// "KEY=VALUE" lines to the Unix socket that $NOTIFY_SOCKET names (a path, or "@name" in the abstract
// namespace). systemd sets it for a unit of Type=notify (deploy/systemd): the unit is started — and
// the units ordered After= it start — only once the program has sent READY=1.
// Threads: any. Throws: nothing. Without $NOTIFY_SOCKET (not started by a service manager) nothing is
// sent; a socket that cannot be reached is logged once per call at warn, and the program goes on.

#include <string>

namespace urs::util {

// How a notification went.
enum class Notified {
  kSent,         // the service manager has it
  kNoManager,    // $NOTIFY_SOCKET is not set: nobody to tell
  kUnreachable,  // $NOTIFY_SOCKET is set but malformed, or sending to it failed (logged)
};

// Sends `state` (e.g. "READY=1", "STOPPING=1", "STATUS=serving") to the service manager.
Notified notify_service_manager(const std::string& state);

// "READY=1": the program serves (its listening socket is open, its components bound, its services registered).
inline Notified notify_ready() { return notify_service_manager("READY=1"); }

}  // namespace urs::util
