#include "container.hpp"

namespace urs::camus_server {

void AgentHostContainer::dispatch(const planet::Request& request, const std::string& caller, Completion done) {
  host_.dispatch(request, caller, planet::Responder::from_callback(std::move(done)));
}

}  // namespace urs::camus_server
