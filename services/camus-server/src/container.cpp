#include "container.hpp"

#include <utility>

#include "urs/planet/call_adapter.hpp"

namespace urs::camus_server {

void AgentHostContainer::dispatch(const planet::Request& request, const Caller& caller, Completion done) {
  host_.dispatch(planet::to_call_request(request, planet::caller_identity(space_, caller.identity, caller.role)),
                 planet::to_call_responder(std::move(done)));
}

}  // namespace urs::camus_server
