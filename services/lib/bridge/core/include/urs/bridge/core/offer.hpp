#pragma once
// The bridge's core speaks of services by what one side offers, in these terms only: no CORBA,
// Planet or DDS type crosses into it (docs/architecture.md, "The bridge").

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace urs::bridge::core {

// A service one side offers, as its adapter reports it.
struct Offer {
  std::string key;             // unique on its side while the offer lasts (a CAMUS name, "<space>/<service>", ...)
  std::string name;            // what the rules' allow/deny globs match: a CAMUS service name, the naming
                               // path of an RT provider's component, "<space>/<service>"
  std::string interface_name;  // the interface's type name, matched by RouteRule::interface
  std::string origin;          // "" for the side's own; else where a bridge brought it from (urslink.origin)
  bool built_in = false;       // a service of the middleware itself (the CAMUS server's camus.*)
  std::map<std::string, std::string> properties;            // a change updates the route (ServiceOffering::update)
  std::vector<std::pair<std::string, std::string>> fields;  // values of a rule's name template, by name
  std::string revision;      // opaque; a change withdraws the route and creates it again (a new description)
  std::string source;        // where a stand-in's calls go, as its urslink.origin shows it: "rtc:<path>:<port>",
                             // "camus:<service>", "dds:<space>/<service>"
  uint32_t deadline_ms = 0;  // the bound its side advertises for each call (0: none); a rule's comes first
};

// The properties that mark what a bridge offers on any side (a CAMUS service's, an RT-Component's):
// where its calls go (Offer::source: "rtc:<path>:<port>", "camus:<service>",
// "dds:<space>/<service>"), which bridge made it, and an RT provider's health. Nothing that carries
// an origin is bridged again (bridgeable()).
inline constexpr const char* kOriginProperty = "urslink.origin";
inline constexpr const char* kBridgeProperty = "urslink.bridge";
inline constexpr const char* kHealthProperty = "urslink.health";  // "ok", "slow", "inactive", "unreachable", ...
// With health "unreachable": since when (Unix seconds) the service's space has been lost.
inline constexpr const char* kUnreachableSinceProperty = "urslink.unreachable_since";

// True if a bridge may carry `offer` to another side: nothing a bridge made (it carries an origin)
// is bridged again, so two bridges never pass a service back and forth; the built-ins never.
bool bridgeable(const Offer& offer);

}  // namespace urs::bridge::core
