#!/usr/bin/env bash
# Installs what is missing, builds, runs every benchmark on loopback and writes the report:
# docs/performance.md (Markdown) and build/bench.json. Takes a few minutes on 2 cores.
# Usage: deploy/bench.sh [--quick]
# URS_GATEWAY_BENCH_SECONDS: how long poses are timed through urs-gateway (default 600, 8 with --quick)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/deploy/install-deps.sh"
"$root/deploy/build.sh"
build=${URS_BUILD_DIR:-$root/build}
pin=()
if (($(nproc) >= 2)); then pin=(--pin); fi  # clients on CPU 0, servers on CPU 1 (tests/bench/pinning.hpp)
table=$(mktemp)
gateway_table=$(mktemp)
"$build/tests/bench/urs-bench" "${pin[@]}" "$@" --json "$build/bench.json" --markdown "$table" 2>"$build/bench.log"
"$build/tests/bench/urs-gateway-bench" "$@" --seconds "${URS_GATEWAY_BENCH_SECONDS:-600}" \
  --json "$build/gateway-bench.json" --markdown "$gateway_table" 2>>"$build/bench.log"
{
  cat "$root/tests/bench/report-header.md"
  echo
  echo "Measured $(date -u +%Y-%m-%d) on $(nproc) cores, $(uname -sr), by \`deploy/bench.sh${*:+ $*}\`."
  echo
  cat "$table"
  echo
  echo "## Poses through urs-gateway to WebSocket clients"
  echo
  echo "\`urs-gateway-bench\`: a robot's localizer at 50 Hz in a DDS domain of its own, urs-gateway following it, and"
  echo "10 WebSocket clients subscribed to \`/poses\`, as 10 dashboards or Foxglove windows; latency from the"
  echo "localizer's sample (the pose's stamp) to its arrival at a client; the gateway's resident memory sampled"
  echo "every second (goals: >= 20 Hz to every client, p99 <= 100 ms, memory flat)."
  echo
  cat "$gateway_table"
  echo
  cat "$root/tests/bench/report-notes.md"
} > "$root/docs/performance.md"
rm -f "$table" "$gateway_table"
cat "$root/docs/performance.md"
