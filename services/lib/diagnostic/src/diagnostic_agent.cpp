#include "urs/diagnostic/diagnostic_agent.hpp"

#include <spdlog/spdlog.h>

#include <thread>

#include "Diagnostic.pb.h"
#include "urs/diagnostic/diagnostic.hpp"

namespace urs::diagnostic {

using agent::CallContext;
using agent::Outcome;

// Every operation but sleep (which blocks) and notify (which publishes through the host's event
// sink) computes in memory, so it runs on the thread that received the call: no hand-off.
DiagnosticAgent::DiagnosticAgent() : TypedAgent(*URS::Diagnostic_echo_Request::descriptor()->file(), "Diagnostic") {
  on<URS::Diagnostic_echo_Request, URS::Diagnostic_echo_Reply>(
      "echo",
      [](const auto& req, auto& rep, const CallContext&) {
        rep.set_result(req.text());
        return Outcome::ok();
      },
      Run::on_receiving_thread);
  on<URS::Diagnostic_add_Request, URS::Diagnostic_add_Reply>(
      "add",
      [](const auto& req, auto& rep, const CallContext&) {
        rep.set_result(req.a() + req.b());
        return Outcome::ok();
      },
      Run::on_receiving_thread);
  on<URS::Diagnostic_sleep_Request, URS::Diagnostic_sleep_Reply>(
      "sleep", [](const auto& req, auto&, const CallContext& ctx) {
        if (auto refused = check_sleep(req.ms())) return Outcome::error(call::Status::BAD_ARGUMENTS, *refused);
        const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(req.ms());
        spdlog::debug("diagnostic: sleep {} ms begins", req.ms());  // the call reached the provider
        // The caller stops waiting at its deadline; so does the agent, which frees its worker.
        if (ctx.deadline < until) {
          std::this_thread::sleep_until(ctx.deadline);
          return Outcome::error(call::Status::DEADLINE_EXCEEDED,
                                "sleep: the caller's deadline came before " + std::to_string(req.ms()) + " ms");
        }
        std::this_thread::sleep_until(until);
        return Outcome::ok();
      });
  on<URS::Diagnostic_blob_Request, URS::Diagnostic_blob_Reply>(
      "blob",
      [](const auto& req, auto& rep, const CallContext&) {
        if (auto refused = check_blob(req.size())) return Outcome::error(call::Status::BAD_ARGUMENTS, *refused);
        rep.set_result(patterned_bytes(req.size()));
        return Outcome::ok();
      },
      Run::on_receiving_thread);
  on<URS::Diagnostic_checksum_Request, URS::Diagnostic_checksum_Reply>(
      "checksum",
      [](const auto& req, auto& rep, const CallContext&) {
        rep.set_result(fnv1a64(req.data().data(), req.data().size()));
        return Outcome::ok();
      },
      Run::on_receiving_thread);
  on<URS::Diagnostic_fail_Request, URS::Diagnostic_fail_Reply>(
      "fail",
      [](const auto& req, auto&, const CallContext&) {
        auto failure = std::make_shared<URS::Failure>();
        failure->set_reason(req.reason());
        failure->set_code(req.code());
        return Outcome::raise(failure, "Failure: " + req.reason());
      },
      Run::on_receiving_thread);
  on<URS::Diagnostic_notify_Request, URS::Diagnostic_notify_Reply>(
      "notify", [](const auto& req, auto&, const CallContext& ctx) {
        if (req.topic().empty()) return Outcome::error(call::Status::BAD_ARGUMENTS, "notify: topic is empty");
        auto published = ctx.events->publish(req.topic(), req);
        if (!published.ok()) return Outcome::error(published.status, published.message);
        return Outcome::ok();
      });
  check_complete();
}

}  // namespace urs::diagnostic
