#pragma once
// A CAMUS service as a service agent: its interface described by the registry, and a
// core::ForwardingAgent whose calls go to it through a Planet client (the CAMUS side's stand-ins'
// source, and any host that offers a CAMUS service elsewhere, e.g. as a CORBA object).

#include <google/protobuf/descriptor.h>

#include <memory>
#include <string>

#include "urs/bridge/core/forwarding_agent.hpp"
#include "urs/planet/client.hpp"
#include "urs/schema/schema.hpp"

namespace urs::bridge {

// Asks the CAMUS registry (camus.registry.Describe) for the interface of `service`, adds its
// description to `pool` and returns the interface's descriptor, valid as long as `pool`. Blocking
// (at most 2 s); not from a Planet callback. Throws util::NotFound (no such service),
// util::Unavailable (the registry cannot say now) or util::ProtocolError (an unusable description).
const google::protobuf::ServiceDescriptor& describe_service(planet::Client& client, const std::string& service,
                                                            schema::SchemaPool& pool);

// The agent forwarding each call to the CAMUS service `service` through `client` (the client calls
// as itself: Planet carries no caller on behalf of another). Once the client is gone, its calls
// answer UNAVAILABLE. The pool holding `interface` outlives the agent.
std::shared_ptr<core::ForwardingAgent> planet_forwarder(std::weak_ptr<planet::Client> client, std::string service,
                                                        const google::protobuf::ServiceDescriptor& interface);

}  // namespace urs::bridge
