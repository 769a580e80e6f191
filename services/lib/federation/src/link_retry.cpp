#include "urs/federation/link_retry.hpp"

#include <spdlog/spdlog.h>

namespace urs::federation {

void LinkRetry::failed(const std::string& why) {
  if (why != failure_) {
    spdlog::error("{}: no link to other spaces yet: {}; trying again every {} s", who_, why, kPeriod.count());
  }
  failure_ = why;
  next_try_ = Clock::now() + kPeriod;
}

void LinkRetry::joined() {
  if (!failure_.empty()) spdlog::info("{}: joined the link to other spaces", who_);
  failure_.clear();
}

}  // namespace urs::federation
