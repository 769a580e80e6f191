#pragma once
// Callbacks the client's components collect while they hold their lock, to run once it is
// released: a user's handler may call back into the client.

#include <functional>
#include <utility>
#include <vector>

#include "urs/planet/client.hpp"

namespace urs::planet::detail {

using Deferred = std::vector<std::function<void()>>;

// Runs every callback in order (one that throws is logged, the rest still run), then clears.
void run_all(Deferred& callbacks);

// Queues `handler(result)`; an empty handler (a oneway's) queues nothing.
void defer_reply(Deferred& out, ReplyHandler handler, CallResult result);

}  // namespace urs::planet::detail
