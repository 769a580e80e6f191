#include "urs/agent/camus.hpp"

#include <utility>

#include "urs/planet/call_adapter.hpp"
#include "urs/schema/schema.hpp"

namespace urs::agent {

camus::RegisterRequest registration(const HostedService& service) {
  camus::RegisterRequest out;
  const google::protobuf::ServiceDescriptor& iface = service.agent->interface();
  auto* info = out.mutable_service();
  info->set_name(service.name);
  info->set_interface(iface.full_name());
  info->set_deadline_ms(service.deadline_ms);
  for (const auto& [key, value] : service.properties) (*info->mutable_properties())[key] = value;
  out.set_descriptor_set(schema::descriptor_set_for(*iface.file()));
  return out;
}

void serve_requests(planet::Client& client, AgentHost& host) {
  // The client's request handler gets only the Requests of its own session with the server, once
  // its handshake is done (the server authenticated by TLS when the client requires it): their
  // Request.caller is that server's word.
  client.set_request_handler([&host, &client](const planet::Request& request, planet::Responder responder) {
    host.dispatch(planet::to_call_request(request, planet::routed_caller(request, client.welcome().space())),
                  planet::to_call_responder(std::move(responder)));
  });
}

}  // namespace urs::agent
