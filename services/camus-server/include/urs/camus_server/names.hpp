#pragma once
// Names the server uses for itself.

#include <array>
#include <string_view>

namespace urs::camus_server {

// Owner of the built-in services and source of the events the server publishes itself. No
// credential may take this name, so no session can speak as the server.
inline constexpr const char* kServerPeerName = "camus-server";

// First topic levels the server publishes on (registry/<service>, context/<key>,
// task/<task>/<run>): sessions may subscribe to them but never publish there.
inline constexpr std::array<std::string_view, 3> kServerTopics = {"registry", "context", "task"};

// True if `topic` lies under one of kServerTopics ("registry" itself included).
inline bool is_server_topic(std::string_view topic) {
  const std::string_view first = topic.substr(0, topic.find('/'));
  for (auto level : kServerTopics) {
    if (first == level) return true;
  }
  return false;
}

}  // namespace urs::camus_server
