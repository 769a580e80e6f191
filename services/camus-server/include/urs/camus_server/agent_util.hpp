#pragma once
// Helpers for the built-in service agents: typed access to the messages a host hands over.

#include <google/protobuf/message.h>

#include "urs/agent/agent.hpp"
#include "urs/camus_server/result.hpp"
#include "urs/planet/call_adapter.hpp"

namespace urs::camus_server {

// `message` as T: the same object when it is a generated T, else a copy parsed into `storage`
// (hosts that use a DynamicMessageFactory).
template <class T>
const T& message_as(const google::protobuf::Message& message, T& storage) {
  if (const auto* typed = dynamic_cast<const T*>(&message)) return *typed;
  storage.ParseFromString(message.SerializeAsString());
  return storage;
}

// Fills `reply` (of any implementation) from a generated message of the same type.
inline void fill_reply(google::protobuf::Message& reply, const google::protobuf::Message& value) {
  if (reply.GetDescriptor() == value.GetDescriptor()) {
    reply.CopyFrom(value);
  } else {
    reply.ParseFromString(value.SerializeAsString());
  }
}

// The Outcome of a refused Result: its status (a Planet status, of the same number) and message.
template <class T>
agent::Outcome refused(const Result<T>& result) {
  return agent::Outcome::error(planet::to_call(result.status()), result.message());
}

}  // namespace urs::camus_server
