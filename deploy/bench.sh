#!/usr/bin/env bash
# Installs what is missing, builds, runs every benchmark on loopback and writes the report:
# docs/performance.md (Markdown) and build/bench.json. Takes a few minutes on 2 cores.
# Usage: deploy/bench.sh [--quick]
# URS_GATEWAY_BENCH_SECONDS: how long poses are timed through urs-gateway (default 600, 8 with --quick)
# URS_BENCH_RUNS: full runs of urs-bench (default 1); with more, the report adds every goal's state
#   across the runs (tests/bench/goals_across_runs.py) and the table is the last run's
# URS_BENCH_WAN=0: leave out the rows across sites (tests/bench/wan_bench.sh, each run after
#   urs-bench: the link over TCP through NAT and a 40 ms path; needs root, left out without it)
set -euo pipefail
source "$(dirname "$0")/prepare.sh"
install_and_build
pin=()
if (($(nproc) >= 2)); then pin=(--pin); fi  # clients on CPU 0, servers on CPU 1 (tests/bench/pinning.hpp)
table=$(mktemp)
gateway_table=$(mktemp)
wan_table=$(mktemp)
wan=${URS_BENCH_WAN:-1}
if [[ "$wan" != 0 && $(id -u) -ne 0 ]]; then
  wan=0
  echo "The rows across sites are not measured: tests/bench/wan_bench.sh needs root (ip netns, iptables)." >"$wan_table"
fi
runs=${URS_BENCH_RUNS:-1}
runs_json=()  # one file per run; the table is the last run's
: >"$build/bench.log"
for ((run = 1; run <= runs; run++)); do
  runs_json+=("$build/bench-$run.json")
  "$build/tests/bench/urs-bench" "${pin[@]}" "$@" --json "${runs_json[-1]}" --markdown "$table" 2>>"$build/bench.log"
  if [[ "$wan" != 0 ]]; then  # its goals counted with the run's (goals_across_runs.py: A.json,B.json)
    URS_BUILD_DIR=$build "$root/tests/bench/wan_bench.sh" "${pin[@]}" "$@" --json "$build/wan-bench-$run.json" \
      --markdown "$wan_table" >/dev/null 2>>"$build/bench.log" ||
      echo "The rows across sites were not measured: wan_bench.sh failed (build/bench.log)." >"$wan_table"
    runs_json[-1]+=",$build/wan-bench-$run.json"
  fi
done
cp "$build/bench-$runs.json" "$build/bench.json"
"$build/tests/bench/urs-gateway-bench" "$@" --seconds "${URS_GATEWAY_BENCH_SECONDS:-600}" \
  --json "$build/gateway-bench.json" --markdown "$gateway_table" 2>>"$build/bench.log"
{
  cat "$root/tests/bench/report-header.md"
  echo
  echo "Measured $(date -u +%Y-%m-%d) on $(nproc) cores, $(uname -sr), by \`deploy/bench.sh${*:+ $*}\`."
  echo
  cat "$table"
  echo
  cat "$root/tests/bench/report-wan.md"
  echo
  cat "$wan_table"
  if ((runs > 1)); then
    echo
    echo "## The goals across $runs full runs"
    echo
    echo "Each run is a whole \`urs-bench\` run, one after the other; the table above is the last one. A latency"
    echo "goal is the run's median ratio (the spread of its per-repetition ratios in brackets); \"runs apart\" is"
    echo "how far the runs' ratios lie from each other (max/min - 1)."
    echo
    python3 "$root/tests/bench/goals_across_runs.py" "${runs_json[@]}"
  fi
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
rm -f "$table" "$gateway_table" "$wan_table"
cat "$root/docs/performance.md"
