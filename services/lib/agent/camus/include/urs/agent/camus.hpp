#pragma once
// A host's service agents offered on a CAMUS server through a Planet client: the CAMUS-facing
// edge of urs/agent/agent.hpp (which knows no middleware).

#include "camus.pb.h"
#include "urs/agent/agent.hpp"
#include "urs/planet/client.hpp"

namespace urs::agent {

// The registration to send for `service` (interface name + descriptor set of its file).
camus::RegisterRequest registration(const HostedService& service);

// Makes `host` answer the requests the server routes to `client` (Client::set_request_handler:
// call it before client.start()). The agents see the caller the server names (Request.caller:
// the calling session's authenticated name and role, in the server's space) as
// CallContext::caller. `host` and `client` outlive the client's I/O thread.
void serve_requests(planet::Client& client, AgentHost& host);

}  // namespace urs::agent
