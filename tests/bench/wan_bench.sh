#!/usr/bin/env bash
# The bench rows across sites: a cross-space call over the link over TCP through the emulated
# internet of tests/e2e/sites (two sites behind NAT, 40 ms each way), against the raw TCP round
# trip of the same path, measured in turns by urs-wan-bench. The programs are the real ones, set
# up as e2e_sites_link sets them up (tests/e2e/sites/link_test.sh, jp_site.sh):
#   site a, jp: omniNames, urs-rtc-manager with a Diagnostic RTC, bridge-jp listening on TCP 7400
#               (forwarded by router a), and `tcp-rtt --serve` on 7500 (forwarded the same way);
#   site b, kr: urs-camus-server, urs-sam with the diagnostic agent, bridge-kr connecting out to
#               router a's public 7400.
# Both directions: kr → jp, urs-wan-bench in site b calling jp/rt.Diagnostic0 through kr's server
# against round trips to the `tcp-rtt --serve`; jp → kr, urs-wan-bench in site a calling kr's
# agent bound in jp (jp-bridge.host_cxt/kr_diag.rtc) against round trips over connections that a
# `tcp-rtt --serve-over` in site b opens to site a's forwarded 7501, as bridge-kr opens the link's.
# Once per loss in WAN_BENCH_LOSSES (default "0 0.01"): without loss a median is what a call
# costs; with 1 % loss the same rows show what a bad path adds. Prints one table in urs-bench's
# format (report.hpp); --json writes its rows, which goals_across_runs.py reads with a run of
# urs-bench. Needs root (ip netns, iptables, NFQUEUE). Numbers are reported, never asserted; what
# could not be measured is said in the table, and why on stderr.
#   tests/bench/wan_bench.sh [--quick] [--pin] [--markdown FILE] [--json FILE]
# URS_BUILD_DIR: the build folder (default build/); --pin: servers on CPU 1, the client on CPU 0.
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build=${URS_BUILD_DIR:-$root/build}
bin=$build/services
sites=$root/tests/e2e/sites
tools=$build/tests/e2e/sites
test_name=wan_bench
source "$root/tests/e2e/steps.sh"
source "$sites/wan.sh"
source "$sites/jp_site.sh"

quick=() pin=() markdown="" json=""
while (($#)); do
  case $1 in
    --quick) quick=(--quick) ;;
    --pin) pin=(--pin) ;;
    --markdown) markdown=$2; shift ;;
    --json) json=$2; shift ;;
    *) die "usage: wan_bench.sh [--quick] [--pin] [--markdown FILE] [--json FILE]" ;;
  esac
  shift
done
[[ $(id -u) -eq 0 ]] || die "needs root for ip netns (run as root, as CI does)"
command -v iptables >/dev/null || die "iptables (Debian: iptables) is not installed"
command -v omniNames >/dev/null || die "omniNames (Debian: omniorb-nameserver) is not installed"
for program in "$tools/wan-delay" "$tools/tcp-rtt" "$build/tests/bench/urs-wan-bench" "$bin/bridge/urs-bridge" \
  "$bin/camus-server/urs-camus-server" "$bin/sam/urs-sam" "$bin/rtc-manager/urs-rtc-manager" "$bin/cli/urs"; do
  [[ -x "$program" ]] || die "$program is not built"
done
SERVER_CPU=()  # the servers on CPU 1 with --pin, as urs-bench's (tests/bench/pinning.hpp)
if ((${#pin[@]})); then SERVER_CPU=(taskset -c 1); fi

top=$(mktemp -d)  # a folder $work per loss (jp_site.sh)
trap 'wan_down; rm -rf "$top"' EXIT
trap 'exit 130' INT TERM

# measure LOSS: the sites up with that loss, the programs started, the rows of each direction into
# $top/LOSS/DIRECTION.md and .json (kr-jp, jp-kr); returns 1, saying why, when the sites, the
# programs or the link do not come up (a direction that fails is said and the other still measured).
measure() {
  local loss=$1 a=$WAN_A_LAN rc=0
  work=$top/$loss WAN_LOG_DIR=$top/$loss
  mkdir -p "$work"
  WAN_LOSS=$loss wan_up "wb${$: -4}" "$tools/wan-delay" || { say "wan_up failed"; return 1; }
  wan_forward 7400 && wan_forward 7500 && wan_forward 7501 || { say "forwarding 7400, 7500 and 7501 failed"; return 1; }
  # jp as e2e_sites_link runs it (jp_site.sh); ip netns exec itself, not in_a (a function, a subshell).
  jp_rt_up || { say "omniNames or urs-rtc-manager did not come up"; return 1; }
  jp_bridge_up "$WAN_A_PUBLIC" || { say "bridge-jp did not come up"; return 1; }
  ip netns exec "$WAN_NS_A" "${SERVER_CPU[@]}" "$tools/tcp-rtt" --serve 0.0.0.0:7500 >"$work/tcp-rtt.log" 2>&1 &
  # kr: everything on site b's own loopback but bridge-kr's connection out.
  ip netns exec "$WAN_NS_B" "${SERVER_CPU[@]}" "$bin/camus-server/urs-camus-server" --space kr \
    --listen 127.0.0.1:7600 --data-dir "$work/camus" --log-level warn >"$work/server.log" 2>&1 &
  eventually 10 in_b bash -c "exec 3<>/dev/tcp/127.0.0.1/7600" 2>/dev/null || { say "kr's server does not listen"; return 1; }
  ip netns exec "$WAN_NS_B" "${SERVER_CPU[@]}" "$bin/sam/urs-sam" --space kr --server 127.0.0.1:7600 \
    --config "$root/services/sam/diagnostic.yaml" --log-level warn >"$work/sam.log" 2>&1 &
  printf 'name: bridge-kr\ndds:\n  domain: 7\n  transport: tcp\n  tcp: {connect: ["%s:7400"]}\n' "$WAN_A_PUBLIC" \
    >"$work/kr-bridge.yaml"
  ip netns exec "$WAN_NS_B" "${SERVER_CPU[@]}" "$bin/bridge/urs-bridge" --space kr --server 127.0.0.1:7600 \
    --config "$work/kr-bridge.yaml" --log-level warn >"$work/bridge-kr.log" 2>&1 &
  disown -a
  # The link comes up in 1-3 s on this path; a stalled first connection is joined again after 20 s
  # (docs/sites.md, Limits).
  local t=$SECONDS
  callable() { in_b "$bin/cli/urs" --server 127.0.0.1:7600 --timeout-ms 5000 call jp/rt.Diagnostic0 echo '{"text":"up"}' \
    >/dev/null 2>&1; }
  bound() { in_a "$bin/cli/urs" rtc --naming "$a:2809" ls jp-bridge.host_cxt 2>/dev/null | grep -q kr_diag.rtc; }
  eventually 90 callable || { say "jp/rt.Diagnostic0 not callable from kr within 90 s"; return 1; }
  eventually 30 bound || { say "kr's diag not bound in jp within 30 s"; return 1; }
  say "loss $loss: the link up both ways $((SECONDS - t)) s after bridge-kr started"
  local path="40 ms each way, $(python3 -c "print(f'{100 * $loss:g}')") % loss"
  ip netns exec "$WAN_NS_B" "$build/tests/bench/urs-wan-bench" "${quick[@]}" "${pin[@]}" --path "$path" \
    --server 127.0.0.1:7600 --service jp/rt.Diagnostic0 --raw "$WAN_A_PUBLIC:7500" \
    --markdown "$work/kr-jp.md" --json "$work/kr-jp.json" >/dev/null 2>"$work/wan-bench-kr-jp.log" ||
    { say "urs-wan-bench kr → jp failed: $(tail -n 3 "$work/wan-bench-kr-jp.log")"; rc=1; }
  ip netns exec "$WAN_NS_A" "$build/tests/bench/urs-wan-bench" "${quick[@]}" "${pin[@]}" --path "$path" \
    --naming "$a:2809" --rtc jp-bridge.host_cxt/kr_diag.rtc --raw-accept 7501 --ready-file "$work/jp-kr.ready" \
    --markdown "$work/jp-kr.md" --json "$work/jp-kr.json" >/dev/null 2>"$work/wan-bench-jp-kr.log" &
  local from_jp=$!
  if eventually 30 test -e "$work/jp-kr.ready"; then
    ip netns exec "$WAN_NS_B" "$tools/tcp-rtt" --serve-over "$WAN_A_PUBLIC:7501" --clients 4 \
      >"$work/tcp-rtt-over.log" 2>&1 &
    disown
  fi
  wait "$from_jp" || { say "urs-wan-bench jp → kr failed: $(tail -n 3 "$work/wan-bench-jp-kr.log")"; rc=1; }
  say "loss $loss: path $(wan_counters)"
  return $rc
}

losses=(${WAN_BENCH_LOSSES:-0 0.01})
for loss in "${losses[@]}"; do
  if ! measure "$loss" >&2; then
    for log in "$top/$loss"/*.log; do [[ -e "$log" ]] && { echo "---- $log"; tail -n 20 "$log"; } >&2; done
    printf 'WAN 40 ms each way, loss %s\tnot all measured: wan_bench.sh says what failed on stderr\n' "$loss" \
      >>"$top/not-measured"
  fi
  wan_down
done
# One table: the rows of every loss, then their other measurements (report.hpp's two tables).
table=$(python3 - "$top" "${json:-/dev/null}" "${#quick[@]}" "${losses[@]}" <<'EOF'
import json, os, sys
top, json_out, quick, losses = sys.argv[1], sys.argv[2], sys.argv[3] != "0", sys.argv[4:]
rows, other, first, second = [], {}, [], []
for loss in losses:
    for direction in ("kr-jp", "jp-kr"):
      if not os.path.exists(f"{top}/{loss}/{direction}.json"):
          continue
      run = json.load(open(f"{top}/{loss}/{direction}.json"))
      rows += run["rows"]
      other.update(run["other"])
      tables = open(f"{top}/{loss}/{direction}.md").read().split("\n\n")
      first += tables[0].strip().splitlines()[2:]
      second += tables[1].strip().splitlines()[2:]
if os.path.exists(f"{top}/not-measured"):
    for line in open(f"{top}/not-measured"):
        key, value = line.rstrip("\n").split("\t")
        other[key] = value
        second.append(f"| {key} | {value} |")
print("| path | payload | median | p99 | spread of medians | vs baseline (spread of per-repetition ratios) | goal |")
print("|---|---|---|---|---|---|---|")
print("\n".join(first))
print()
print("| measurement | value |\n|---|---|")
print("\n".join(second))
with open(json_out, "w") as out:
    json.dump({"quick": quick, "rows": rows, "other": other}, out, ensure_ascii=False)
EOF
)
[[ -n "$markdown" ]] && printf '%s\n' "$table" >"$markdown"
printf '%s\n' "$table"
