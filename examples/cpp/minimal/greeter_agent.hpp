#pragma once
// The agent serving Example::Greeter. Calls run on the host's worker threads: the counter is atomic.

#include <atomic>

#include "urs/agent/typed_agent.hpp"

namespace example {

class GreeterAgent : public urs::agent::TypedAgent {
 public:
  GreeterAgent();

 private:
  std::atomic<unsigned> greetings_{0};
};

}  // namespace example
