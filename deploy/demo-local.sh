#!/usr/bin/env bash
# Every piece on this machine, without containers (the main job, deploy/demo.sh, runs the two
# spaces as containers): installs what is missing, builds, and runs
# - a CAMUS space (urs-camus-server + urs-sam with the diagnostic agent) driven with the `urs`
#   CLI: list, call, an exception, a deadline, an event, context, a task, and a server crash with
#   the SAM re-registering by itself;
# - an RT space (omniNames + urs-rtc-manager) driven with `urs rtc`: the connector wiring a
#   service port by itself, lifecycle, a data port in big-endian CDR;
# - urs-bridge linking the two: the Diagnostic RTC called from CAMUS, the SAM's agent as an RTC, a
#   data port feeding CAMUS context, and deactivation withdrawing it all.
# Everything runs on 127.0.0.1; logs go to $URS_DEMO_DIR.
set -euo pipefail
source "$(dirname "$0")/prepare.sh"
install_and_build "${URS_DEMO_NO_BUILD:-}"  # the e2e test runs the demo on binaries already built
bin=$build/services
work=${URS_DEMO_DIR:-$(mktemp -d /tmp/urs-demo-XXXXXX)}
mkdir -p "$work"
echo "demo-token-$RANDOM$RANDOM" > "$work/token"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT

start_server() {
  "$bin/camus-server/urs-camus-server" --space demo --listen "127.0.0.1:${1}" --token-file "$work/token" \
    --token-role operator --data-dir "$work/data" --port-file "$work/port" >>"$work/server.log" 2>&1 &
  server_pid=$!
  pids+=("$server_pid")
  for _ in $(seq 100); do [[ -s "$work/port" ]] && return 0; sleep 0.05; done
  echo "server did not start; see $work/server.log" >&2; exit 1
}
step() { printf '\n\033[1m== %s\033[0m\n' "$*"; }
urs() { "$bin/cli/urs" --server "127.0.0.1:$(cat "$work/port")" --token-file "$work/token" "$@"; }

rm -f "$work/port"
start_server 0
"$bin/sam/urs-sam" --space demo --server "127.0.0.1:$(cat "$work/port")" --token-file "$work/token" \
  --config "$root/services/sam/diagnostic.yaml" >>"$work/sam.log" 2>&1 &
pids+=("$!")
for _ in $(seq 100); do urs ls diag 2>/dev/null | grep -q '^diag ' && break; sleep 0.05; done

step "services in space 'demo'"; urs ls
step "interface of diag"; urs describe diag
step "call diag.echo"; urs call diag echo '{"text":"hello from the demo"}'
step "call diag.fail (an IDL exception travels back typed)"; urs call diag fail '{"reason":"battery low","code":7}' || true
step "call diag.sleep 2 s with a 300 ms deadline"; urs call diag sleep '{"ms":2000}' --deadline-ms 300 || true
step "an agent's event reaches a watcher"
urs watch 'demo/#' --count 1 --for-ms 5000 & watch_pid=$!
sleep 0.3; urs call diag notify '{"topic":"demo/door","text":"opened"}'; wait $watch_pid || true
step "context"; urs context set room/light '{"on":true,"lux":420}'; urs context get room/light
step "a declarative task"
cat > "$work/task.yaml" <<'YAML'
name: greet
steps:
  - call: {service: diag, operation: echo, args: {text: hi}}
  - sleep: {ms: 100}
  - call: {service: diag, operation: add, args: {a: 1, b: 2}}
YAML
urs task run --file "$work/task.yaml" --wait
step "kill -9 the server and restart it; the SAM re-registers by itself"
port=$(cat "$work/port"); kill -9 "$server_pid"; wait "$server_pid" 2>/dev/null || true
start_server "$port"; t0=$(date +%s%N)
until urs --timeout-ms 500 ls diag 2>/dev/null | grep -q '^diag '; do sleep 0.02; done
echo "diag listed again $(( ($(date +%s%N) - t0) / 1000000 )) ms after the restart"
urs call diag echo '{"text":"still here"}'
urs context get room/light

step "RT space: omniNames and urs-rtc-manager (services/rtc-manager/example.yaml)"
naming_port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
mkdir -p "$work/naming"
omniNames -start "$naming_port" -datadir "$work/naming" -ORBendPoint "giop:tcp:127.0.0.1:$naming_port" \
  >>"$work/omninames.log" 2>&1 &
pids+=("$!")
for _ in $(seq 100); do (exec 3<>"/dev/tcp/127.0.0.1/$naming_port") 2>/dev/null && break; sleep 0.05; done
"$bin/rtc-manager/urs-rtc-manager" --space demo --naming "127.0.0.1:$naming_port" --host demo-host \
  --config "$root/services/rtc-manager/example.yaml" --ready-file "$work/rtc.ready" >>"$work/rtc-manager.log" 2>&1 &
pids+=("$!")
for _ in $(seq 200); do [[ -s "$work/rtc.ready" ]] && break; sleep 0.05; done
[[ -s "$work/rtc.ready" ]] || { echo "urs-rtc-manager did not start; see $work/rtc-manager.log" >&2; exit 1; }
rtc() { "$bin/cli/urs" rtc --naming "127.0.0.1:$naming_port" "$@"; }
h=demo-host.host_cxt
rtc ls -l
step "the connector wired DiagnosticCaller0 to Diagnostic0 by itself; activate both"
for _ in $(seq 100); do rtc cat "$h/Diagnostic0.rtc:diagnostic" | grep -q '1 connection' && break; sleep 0.05; done
rtc cat "$h/Diagnostic0.rtc:diagnostic" | grep -E 'connection|ports:'
rtc act "$h/Diagnostic0.rtc" "$h/DiagnosticCaller0.rtc"
sleep 0.5
rtc deact "$h/DiagnosticCaller0.rtc"
grep -oE 'DiagnosticCaller0: [0-9]+ echo replies, [0-9]+ failures' "$work/rtc-manager.log"
step "deactivating an inactive component is refused as the standard says"
rtc deact "$h/DiagnosticCaller0.rtc" || true
step "a data port: Counter0.count -> Sink0.count in big-endian CDR"
rtc con "$h/Counter0.rtc:count" "$h/Sink0.rtc:count" dataport.serializer.cdr.endian=big
rtc act "$h/Sink0.rtc" "$h/Counter0.rtc"
sleep 0.5
rtc deact "$h/Counter0.rtc" "$h/Sink0.rtc"
grep -oE 'Sink0: received [0-9]+ counts' "$work/rtc-manager.log"

step "the bridge links both worlds: urs-bridge (services/bridge/example.yaml)"
"$bin/bridge/urs-bridge" --space demo --server "127.0.0.1:$(cat "$work/port")" --token-file "$work/token" \
  --naming "127.0.0.1:$naming_port" --host demo-host --config "$root/services/bridge/example.yaml" \
  --ready-file "$work/bridge.ready" >>"$work/bridge.log" 2>&1 &
pids+=("$!")
for _ in $(seq 200); do urs --timeout-ms 500 ls rt.Diagnostic0 2>/dev/null | grep -q '^rt\.Diagnostic0 ' && break; sleep 0.05; done
urs ls
step "a CAMUS client calls the Diagnostic RTC through the bridge, exception included"
urs call rt.Diagnostic0 echo '{"text":"hello RT, from CAMUS"}'
urs call rt.Diagnostic0 fail '{"reason":"wheel stuck","code":3}' || true
step "the SAM's diag is an RTC for RT consumers; a Counter's data port feeds CAMUS context"
for _ in $(seq 100); do rtc ls | grep -q camus_diag && break; sleep 0.05; done
rtc ls -l "$h/camus_diag.rtc"
rtc act "$h/Counter0.rtc"
sleep 0.3
urs context get counter.count
rtc deact "$h/Counter0.rtc"
step "deactivating the bridge RTC withdraws both directions"
rtc deact "$h/Bridge0.rtc"
for _ in $(seq 100); do urs --timeout-ms 500 ls rt.Diagnostic0 2>/dev/null | grep -q '^rt\.Diagnostic0 ' || break; sleep 0.05; done
urs ls 'rt.*'
rtc ls | grep -c camus_diag || true
step "done; logs in $work"
