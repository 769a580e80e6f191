#pragma once
// What the bridge's adapters share (internal): the properties that mark what a bridge offers, and
// how one adapter asks another for the agent that forwards a stand-in's calls.

#include <functional>
#include <memory>

#include "urs/agent/agent.hpp"
#include "urs/bridge/core/route_reconciler.hpp"

namespace urs::bridge {

// On everything a bridge offers (a CAMUS property, a component property): where its calls go,
// core::Offer::source ("rtc:<path>:<port>", "camus:<service>", "dds:<space>/<service>"). Nothing
// that carries it is bridged again (core::bridgeable).
inline constexpr const char* kOriginProperty = "urslink.origin";
inline constexpr const char* kBridgeProperty = "urslink.bridge";  // the bridge's name
inline constexpr const char* kHealthProperty = "urslink.health";  // of an RT provider: "ok", "slow", "inactive", ...

// The "consume a service" capability of the adapter of a route's source side: the agent a
// stand-in hosts, forwarding each call to the service `route.offer` stands for. Throws
// std::exception saying why it cannot (the route is refused and tried again).
using MakeForwarder = std::function<std::shared_ptr<agent::ServiceAgent>(const core::Route& route)>;

}  // namespace urs::bridge
