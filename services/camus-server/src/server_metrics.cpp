#include "server_metrics.hpp"

#include <map>

namespace urs::camus_server {
namespace {

using metrics::Kind;
using metrics::Sample;
using Counts = std::vector<std::pair<std::string, uint64_t>>;

// Every limit of the server, so that each has a series from the start (a rate over a series that
// appears with its first refusal would miss that refusal).
const char* const kLimits[] = {"max_connections",
                               "max_connections_per_address",
                               "max_sessions_per_credential",
                               "max_buffered_bytes",
                               "max_buffered_bytes_per_credential",
                               "max_send_queue_bytes",
                               "max_hello_bytes",
                               "chunk_bytes",
                               "max_message_bytes",
                               "max_reassembly_bytes",
                               "max_partial_messages",
                               "handshake_timeout",
                               "max_deadline_ms",
                               "max_pending_calls",
                               "max_pending_calls_per_credential",
                               "max_pending_calls_per_session",
                               "event_queue",
                               "event_queue_per_credential",
                               "event_queue_per_session",
                               "event_queue_bytes",
                               "event_queue_bytes_per_credential",
                               "max_subscriptions",
                               "max_subscriptions_per_credential",
                               "max_subscriptions_per_session"};
const char* const kAuthenticationFailures[] = {"wrong_token", "unknown_certificate", "token_required",
                                               "plaintext_token", "role_not_granted"};

// One sample per name of `known` (0 unless counted) and per other name counted, labelled `label`.
std::vector<Sample> by_name(const char* label, const std::vector<const Counts*>& counted,
                            const std::vector<std::string>& known) {
  std::map<std::string, double> totals;
  for (const auto& name : known) totals[name] = 0;
  for (const Counts* counts : counted) {
    for (const auto& [name, count] : *counts) totals[name] += static_cast<double>(count);
  }
  std::vector<Sample> samples;
  for (const auto& [name, total] : totals) samples.push_back({{{label, name}}, total});
  return samples;
}

std::vector<Sample> one(double value) { return {{{}, value}}; }

}  // namespace

void add_server_metrics(metrics::Metrics& metrics, const planet::Server& server, const Router& router,
                        const Registry& registry, const EventBus& bus) {
  metrics.add_scraped("urslink_planet_connections", "Open Planet connections, handshaking ones included.", Kind::kGauge,
                      [&server] { return one(static_cast<double>(server.stats().connections)); });
  metrics.add_scraped("urslink_planet_sessions", "Open Planet sessions (handshake done).", Kind::kGauge,
                      [&server] { return one(static_cast<double>(server.stats().sessions)); });
  metrics.add_scraped("urslink_planet_resumable_sessions", "Closed Planet sessions kept resumable.", Kind::kGauge,
                      [&server] { return one(static_cast<double>(server.stats().resumable_sessions)); });
  metrics.add_scraped("urslink_planet_buffered_bytes",
                      "Bytes in the reassembly buffers and send queues of every Planet session.", Kind::kGauge,
                      [&server] { return one(static_cast<double>(server.stats().buffered_bytes)); });
  metrics.add_scraped("urslink_planet_authentication_failures_total",
                      "Planet handshakes refused for their credential, by reason (wrong_token, unknown_certificate, "
                      "token_required, plaintext_token, role_not_granted).",
                      Kind::kCounter, [&server] {
                        const auto stats = server.stats();
                        return by_name("reason", {&stats.authentication_failures},
                                       {std::begin(kAuthenticationFailures), std::end(kAuthenticationFailures)});
                      });
  metrics.add_scraped("urslink_planet_protocol_errors_total",
                      "Planet connections closed for what they sent, by error (a protocol error code, BAD_HELLO, "
                      "UNEXPECTED_FRAME).",
                      Kind::kCounter, [&server] {
                        const auto stats = server.stats();
                        return by_name("error", {&stats.protocol_errors}, {});
                      });
  metrics.add_scraped(
      "urslink_refusals_total",
      "What a limit refused (a connection, a session, a frame, a call, an event, a subscription), by the limit's name.",
      Kind::kCounter, [&server, &router, &bus] {
        const auto transport = server.stats().refusals;
        const auto calls = router.refusals();
        const auto events = bus.stats().refusals;
        return by_name("limit", {&transport, &calls, &events}, {std::begin(kLimits), std::end(kLimits)});
      });
  metrics.add_scraped("urslink_camus_pending_calls", "Calls routed and waiting for their reply.", Kind::kGauge,
                      [&router] { return one(static_cast<double>(router.pending())); });
  metrics.add_scraped("urslink_camus_services", "Services in the registry, built-ins included.", Kind::kGauge,
                      [&registry] { return one(static_cast<double>(registry.list("").size())); });
  metrics.add_scraped("urslink_camus_events_published_total", "Events sequenced and stored.", Kind::kCounter,
                      [&bus] { return one(static_cast<double>(bus.stats().published)); });
  metrics.add_scraped("urslink_camus_event_deliveries_total",
                      "Events handed to subscribers (live and replayed), one per subscriber.", Kind::kCounter,
                      [&bus] { return one(static_cast<double>(bus.stats().delivered)); });
  metrics.add_scraped("urslink_camus_event_deliveries_dropped_total",
                      "Events a subscriber could not take (its session gone or closing).", Kind::kCounter,
                      [&bus] { return one(static_cast<double>(bus.stats().dropped)); });
  metrics.add_scraped("urslink_camus_event_queue_operations",
                      "Publishes and subscribes waiting for the event bus (its queue depth).", Kind::kGauge,
                      [&bus] { return one(static_cast<double>(bus.stats().queued)); });
  metrics.add_scraped("urslink_camus_event_queue_bytes", "Bytes of the operations waiting for the event bus.",
                      Kind::kGauge, [&bus] { return one(static_cast<double>(bus.stats().queued_bytes)); });
  metrics.add_scraped("urslink_camus_subscriptions", "Event subscriptions, of sessions and of the server.",
                      Kind::kGauge, [&bus] { return one(static_cast<double>(bus.stats().subscriptions)); });
}

}  // namespace urs::camus_server
