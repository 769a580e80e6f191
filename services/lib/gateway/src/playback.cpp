#include "urs/gateway/playback.hpp"

#include <algorithm>
#include <vector>

#include "urs/gateway/foxglove_json.hpp"
#include "urs/schema/json.hpp"

namespace urs::gateway {

namespace {

// `json` (the Foxglove side's) into `message`; "" or the error.
std::string parse(const std::string& json, google::protobuf::Message& message) {
  std::string canonical;
  std::string error = from_foxglove_json(json, *message.GetDescriptor(), canonical);
  if (!error.empty()) return error;
  return schema::json_to_message(canonical, message);
}

bool derived(const std::string& topic) {
  if (topic == "/graph" || topic == "/trails") return true;
  // "/<space>/<robot>/pose"
  const auto slashes = std::count(topic.begin(), topic.end(), '/');
  return slashes == 3 && topic.size() > 5 && topic.compare(topic.size() - 5, 5, "/pose") == 0;
}

}  // namespace

std::string replay(Gateway& gateway, const std::string& topic, const std::string& json) {
  std::string error;
  if (topic == "/poses") {
    Pose pose;
    if ((error = parse(json, pose)).empty()) gateway.pose(pose);
  } else if (topic == "/context") {
    ContextEntry entry;
    if ((error = parse(json, entry)).empty()) gateway.context(entry);
  } else if (topic == "/events") {
    Event event;
    if ((error = parse(json, event)).empty()) gateway.event(event);
  } else if (topic == "/calls") {
    Call call;
    if ((error = parse(json, call)).empty()) gateway.call(call);
  } else if (topic == "/services") {
    Services services;
    if ((error = parse(json, services)).empty()) {
      gateway.services(kPlaybackSource, {services.services().begin(), services.services().end()});
    }
  } else if (topic == "/components") {
    Components components;
    if ((error = parse(json, components)).empty()) {
      gateway.components(kPlaybackSource, {components.components().begin(), components.components().end()});
    }
  } else if (!derived(topic)) {
    error = "not a topic the gateway takes: " + topic +
            " (it takes /poses, /context, /events, /calls, /services and /components)";
  }
  return error;
}

}  // namespace urs::gateway
