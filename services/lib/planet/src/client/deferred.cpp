#include "client/deferred.hpp"

#include <spdlog/spdlog.h>

#include <exception>

namespace urs::planet::detail {

void run_all(Deferred& callbacks) {
  for (auto& callback : callbacks) {
    try {
      callback();
    } catch (const std::exception& exception) {
      spdlog::error("planet: client callback threw: {}", exception.what());
    }
  }
  callbacks.clear();
}

void defer_reply(Deferred& out, ReplyHandler handler, CallResult result) {
  if (!handler) return;
  out.push_back([handler = std::move(handler), result = std::move(result)]() mutable { handler(std::move(result)); });
}

}  // namespace urs::planet::detail
