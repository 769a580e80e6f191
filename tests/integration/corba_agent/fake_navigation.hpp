#pragma once
// A small URC::Navigation service agent for the hosting tests: a base that jumps to its target.
// moveTo publishes the new URC.Pose2D on topic "pose"; targets farther than 100 m raise
// URC::InvalidTarget; speeds over max_speed (800 mm/s) raise URC::InvalidArgument.

#include <memory>

#include "urs/agent/agent.hpp"

namespace urs::test {

std::shared_ptr<agent::ServiceAgent> make_fake_navigation();

}  // namespace urs::test
