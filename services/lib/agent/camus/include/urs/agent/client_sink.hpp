#pragma once
// EventSink that publishes through a Planet client (at-least-once, queued while disconnected).

#include "urs/agent/agent.hpp"
#include "urs/planet/call_adapter.hpp"
#include "urs/planet/client.hpp"

namespace urs::agent {

class ClientEventSink : public EventSink {
 public:
  explicit ClientEventSink(planet::Client& client) : client_(client) {}
  call::Reply publish(const std::string& topic, const google::protobuf::Message& event) override {
    return planet::to_reply(client_.publish(topic, event.SerializeAsString(), event.GetTypeName()));
  }

 private:
  planet::Client& client_;
};

}  // namespace urs::agent
