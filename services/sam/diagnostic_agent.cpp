#include "diagnostic_agent.hpp"

#include <algorithm>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <thread>

#include "Diagnostic.pb.h"

namespace urs::sam {

using agent::CallContext;
using agent::Outcome;

namespace {
constexpr uint32_t kMaxBlobBytes = 64u << 20;
constexpr uint32_t kMaxSleepMs = 10u * 60u * 1000u;

// size bytes with byte i = i % 251: one period, then copies of what is already filled, doubling
// (a per-byte loop costs ~1 ms for a 921,600-byte image, which would dominate the call).
std::string patterned_bytes(uint32_t size) {
  std::string data(size, '\0');
  const uint32_t period = std::min<uint32_t>(size, 251);
  for (uint32_t i = 0; i < period; ++i) data[i] = static_cast<char>(i);
  for (uint32_t filled = period; filled < size;) {
    const uint32_t n = std::min(filled, size - filled);  // filled is a multiple of 251
    std::memcpy(&data[filled], data.data(), n);
    filled += n;
  }
  return data;
}

uint64_t fnv1a64(const std::string& data) {
  uint64_t hash = 14695981039346656037ull;
  for (unsigned char c : data) {
    hash ^= c;
    hash *= 1099511628211ull;
  }
  return hash;
}
}  // namespace

DiagnosticAgent::DiagnosticAgent()
    : TypedAgent(*URS::Diagnostic_echo_Request::descriptor()->file(), "Diagnostic") {
  on<URS::Diagnostic_echo_Request, URS::Diagnostic_echo_Reply>(
      "echo", [](const auto& req, auto& rep, const CallContext&) {
        rep.set_result(req.text());
        return Outcome::ok();
      });
  on<URS::Diagnostic_add_Request, URS::Diagnostic_add_Reply>(
      "add", [](const auto& req, auto& rep, const CallContext&) {
        rep.set_result(req.a() + req.b());
        return Outcome::ok();
      });
  on<URS::Diagnostic_sleep_Request, URS::Diagnostic_sleep_Reply>(
      "sleep", [](const auto& req, auto&, const CallContext&) {
        if (req.ms() > kMaxSleepMs) {
          return Outcome::error(planet::BAD_ARGUMENTS, "sleep: ms=" + std::to_string(req.ms()) +
                                                           " is over the limit of " +
                                                           std::to_string(kMaxSleepMs));
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(req.ms()));
        return Outcome::ok();
      });
  on<URS::Diagnostic_blob_Request, URS::Diagnostic_blob_Reply>(
      "blob", [](const auto& req, auto& rep, const CallContext&) {
        if (req.size() > kMaxBlobBytes) {
          return Outcome::error(planet::BAD_ARGUMENTS, "blob: size=" + std::to_string(req.size()) +
                                                           " is over the limit of " +
                                                           std::to_string(kMaxBlobBytes) + " bytes");
        }
        rep.set_result(patterned_bytes(req.size()));
        return Outcome::ok();
      });
  on<URS::Diagnostic_checksum_Request, URS::Diagnostic_checksum_Reply>(
      "checksum", [](const auto& req, auto& rep, const CallContext&) {
        rep.set_result(fnv1a64(req.data()));
        return Outcome::ok();
      });
  on<URS::Diagnostic_fail_Request, URS::Diagnostic_fail_Reply>(
      "fail", [](const auto& req, auto&, const CallContext&) {
        auto failure = std::make_shared<URS::Failure>();
        failure->set_reason(req.reason());
        failure->set_code(req.code());
        return Outcome::raise(failure, "Failure: " + req.reason());
      });
  on<URS::Diagnostic_notify_Request, URS::Diagnostic_notify_Reply>(
      "notify", [](const auto& req, auto&, const CallContext& ctx) {
        if (req.topic().empty()) return Outcome::error(planet::BAD_ARGUMENTS, "notify: topic is empty");
        auto published = ctx.events->publish(req.topic(), req);
        if (!published.ok()) return Outcome::error(published.status, published.message);
        return Outcome::ok();
      });
  check_complete();
}

}  // namespace urs::sam
