#pragma once
// What urs-camus-server reports besides its calls (docs/operations.md, "Monitoring"): its Planet
// transport (connections, sessions, refusals, authentication failures, protocol errors), the
// router (pending calls, refusals), the registry (services) and the event bus (events published,
// delivered and dropped, queue depth, subscriptions, refusals). All read when Prometheus scrapes.

#include "urs/camus_server/event_bus.hpp"
#include "urs/camus_server/registry.hpp"
#include "urs/camus_server/router.hpp"
#include "urs/metrics/metrics.hpp"
#include "urs/planet/server.hpp"

namespace urs::camus_server {

// Adds the server's families to `metrics`; every argument outlives it.
void add_server_metrics(metrics::Metrics& metrics, const planet::Server& server, const Router& router,
                        const Registry& registry, const EventBus& bus);

}  // namespace urs::camus_server
