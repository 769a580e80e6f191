#include "urs/bridge/dds/call_audit.hpp"

#include <spdlog/sinks/rotating_file_sink.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <ctime>
#include <stdexcept>

#include "urs/bridge/dds/call_authorization.hpp"  // federation::kVerifiedSpaceRole
#include "urs/util/json_text.hpp"
#include "urs/util/trace.hpp"

namespace urs::bridge {

namespace {

// "2026-11-28T09:20:15.123456Z"
std::string utc_time(std::chrono::system_clock::time_point time) {
  const auto since = time.time_since_epoch();
  const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(since);
  const auto micros = std::chrono::duration_cast<std::chrono::microseconds>(since - seconds).count();
  const std::time_t t = static_cast<std::time_t>(seconds.count());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[96];  // room for any int the format could print
  std::snprintf(text, sizeof text, "%04d-%02d-%02dT%02d:%02d:%02d.%06lldZ", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<long long>(micros));
  return text;
}

}  // namespace

std::string audit_line(const AuditEntry& e) {
  std::string line = "{\"time\":\"" + utc_time(e.time) + "\"";
  line += ",\"caller_space\":" + util::json_string(e.caller.space);
  line += ",\"caller\":" + util::json_string(e.caller.name);
  line += std::string(",\"space_verified\":") + (e.caller.role == federation::kVerifiedSpaceRole ? "true" : "false");
  line += ",\"service\":" + util::json_string(e.service);
  line += ",\"operation\":" + util::json_string(e.operation);
  line += std::string(",\"oneway\":") + (e.oneway ? "true" : "false");
  line += ",\"status\":\"" + std::string(call::status_name(e.status)) + "\"";
  if (e.refusal) line += ",\"reason\":" + util::json_string(*e.refusal);
  if (!e.trace_id.empty()) line += ",\"trace_id\":" + util::json_string(e.trace_id);
  line += ",\"duration_us\":" + std::to_string(e.duration.count()) + "}";
  return line;
}

std::shared_ptr<CallAudit> CallAudit::open(const AuditConfig& config) {
  std::shared_ptr<spdlog::sinks::rotating_file_sink_mt> sink;
  try {
    sink = std::make_shared<spdlog::sinks::rotating_file_sink_mt>(config.file, config.max_bytes, config.files);
  } catch (const spdlog::spdlog_ex& e) {
    throw std::runtime_error("dds.audit.file '" + config.file + "' cannot be opened: " + e.what());
  }
  // Not registered with spdlog: the bridge's own log and level never reach or filter this one.
  auto logger = std::make_shared<spdlog::logger>("urs-audit", std::move(sink));
  logger->set_pattern("%v");
  logger->set_level(spdlog::level::info);
  logger->flush_on(spdlog::level::info);
  return std::shared_ptr<CallAudit>(new CallAudit(std::move(logger)));
}

CallAudit::CallAudit(std::shared_ptr<spdlog::logger> logger) : logger_(std::move(logger)) {}

CallAudit::~CallAudit() = default;

void CallAudit::record(const AuditEntry& entry) {
  try {
    logger_->info(audit_line(entry));
  } catch (const std::exception& e) {  // a full disk must not fail the call
    spdlog::error("audit log: {}", e.what());
  }
}

namespace {

AuditEntry entry_of(const call::Request& request, std::chrono::steady_clock::time_point arrived) {
  AuditEntry entry;
  entry.time = std::chrono::system_clock::now() - std::chrono::duration_cast<std::chrono::system_clock::duration>(
                                                      std::chrono::steady_clock::now() - arrived);
  entry.caller = request.caller;
  entry.service = request.service;
  entry.operation = request.operation;
  entry.oneway = request.oneway;
  if (const auto trace = util::TraceContext::parse(request.traceparent)) entry.trace_id = trace->trace_id_hex();
  return entry;
}

}  // namespace

void CallAudit::record_refusal(const call::Request& request, const std::string& reason) {
  AuditEntry entry = entry_of(request, std::chrono::steady_clock::now());
  entry.status = call::Status::PERMISSION_DENIED;
  entry.refusal = reason;
  record(entry);
}

call::Responder CallAudit::recording(const call::Request& request, std::chrono::steady_clock::time_point arrived,
                                     call::Responder responder) {
  AuditEntry entry = entry_of(request, arrived);
  if (request.oneway) {
    entry.duration = std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - arrived);
    record(entry);
    return responder;
  }
  auto inner = std::make_shared<call::Responder>(std::move(responder));
  return call::Responder::from_callback([audit = shared_from_this(), entry = std::move(entry), arrived,
                                         inner](call::Reply reply) mutable {
    entry.status = reply.status;
    entry.duration = std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - arrived);
    audit->record(entry);
    inner->reply(std::move(reply));
  });
}

}  // namespace urs::bridge
