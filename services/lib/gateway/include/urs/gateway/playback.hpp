#pragma once
// Playing a recording back through the gateway (docs/dashboard.md, "Recording and playback"): a
// gateway started with --playback offers clientPublish to operators, and a player (urs play)
// publishes a recording's channels into it. Each message is taken as if a source had reported it,
// so the picture, the latched values, the per-robot channels, the trails and the connection graph
// are made as for a live space:
//
//   /poses  -> ViewSink::pose       /context    -> ViewSink::context     /events -> ViewSink::event
//   /calls  -> Gateway::call        /services   -> ViewSink::services    /components -> ViewSink::components
//
// /graph, /trails and /<space>/<robot>/pose are derived by the gateway from the others: a message
// on them is taken and left out. Anything else is refused. Messages are the Foxglove side's JSON
// (foxglove_json.hpp), as recorded.

#include <string>

#include "urs/gateway/gateway.hpp"

namespace urs::gateway {

// The source name a played recording's services and components are reported under.
inline constexpr const char* kPlaybackSource = "playback";

// Takes one published message for `topic`; returns "" if taken, else why not (e.g. "JSON for
// urs.gateway.Pose: ..." or "not a topic the gateway takes: /foo"). Thread-safe as the Gateway is.
std::string replay(Gateway& gateway, const std::string& topic, const std::string& json);

}  // namespace urs::gateway
