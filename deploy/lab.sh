#!/usr/bin/env bash
# The papers' experiments, reproducible by a user: one space holding both middlewares as local
# processes (omniNames, urs-rtc-manager with the robot, localizer, camera, TTS and voice
# recognition RTCs, urs-camus-server, urs-sam with the diagnostic agent, urs-bridge), then
#   1. the square path at 500 mm/s driven (a) by an RT consumer straight to the robot RTC and
#      (b) by a CAMUS client through the bridge, both traced, plotted and tabulated;
#   2. speed changes 200 -> 800 -> 500 -> 0 mm/s through the bridge, plotted;
#   3. camera, image recognition, TTS and voice recognition RTCs used from CAMUS through the bridge;
# and a look at both directions (an RT consumer calling the SAM's agent) and at the localizer's
# data port feeding CAMUS context. Outputs in ${URS_LAB_OUT:-build/lab}: experiments.md,
# square.svg, speed.svg, CSV and JSON. docs/experiments.md explains them.
#   URS_LAB_TIME_SCALE  simulated seconds per wall second (default 1, the papers' pace; tests use 10)
#   URS_LAB_NO_BUILD=1  use the binaries already built in ${URS_BUILD_DIR:-build}
set -euo pipefail
source "$(dirname "$0")/prepare.sh"
install_and_build "${URS_LAB_NO_BUILD:-}"
bin=$build/services
out=${URS_LAB_OUT:-$build/lab}
scale=${URS_LAB_TIME_SCALE:-1}
work=$(mktemp -d /tmp/urs-lab-XXXXXX)
# A DDS domain of its own for the robot's world state: the first of 10..230 whose lock in
# /tmp/urs-dds-domains no other run (test, benchmark, lab) holds; held until this script exits.
mkdir -p /tmp/urs-dds-domains && chmod 1777 /tmp/urs-dds-domains 2>/dev/null || true
for ((i = 0; i < 221; i++)); do
  domain=$(( 10 + ($$ + i) % 221 ))
  exec {domain_lock}>>"/tmp/urs-dds-domains/$domain"
  flock -n "$domain_lock" && break
  exec {domain_lock}>&-
  domain=""
done
[[ -n "$domain" ]] || { echo "lab: no free DDS domain (locks in /tmp/urs-dds-domains)" >&2; exit 1; }
mkdir -p "$out" "$work/naming" "$work/data"
rm -f "$out"/square-*.{csv,md,json}

pids=()
cleanup() {
  local rc=$?
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
  if [[ $rc -ne 0 ]]; then echo "lab: failed (exit $rc); logs in $work" >&2; else rm -rf "$work"; fi
}
trap cleanup EXIT
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
step() { printf '\n\033[1m== %s\033[0m\n' "$*"; }
wait_for() {  # wait_for SECONDS DESCRIPTION COMMAND...
  local seconds=$1 what=$2; shift 2
  for _ in $(seq $(( seconds * 20 ))); do "$@" >/dev/null 2>&1 && return 0; sleep 0.05; done
  echo "lab: $what did not happen within $seconds s; logs in $work" >&2; exit 1
}

step "the lab: omniNames, urs-rtc-manager (devices as RTCs), urs-camus-server, urs-sam, urs-bridge"
naming=127.0.0.1:$(free_port)
omniNames -start "${naming#*:}" -datadir "$work/naming" -ORBendPoint "giop:tcp:$naming" >"$work/omninames.log" 2>&1 &
pids+=("$!")
wait_for 10 "omniNames listening" bash -c "exec 3<>/dev/tcp/${naming%:*}/${naming#*:}"
"$bin/camus-server/urs-camus-server" --space lab --listen 127.0.0.1:0 --port-file "$work/port" \
  --data-dir "$work/data" >"$work/server.log" 2>&1 &
pids+=("$!")
wait_for 10 "urs-camus-server listening" test -s "$work/port"
server=127.0.0.1:$(cat "$work/port")
sed -e "s/@DOMAIN@/$domain/g" -e "s/@TIME_SCALE@/$scale/g" "$root/deploy/lab/rtc.yaml" >"$work/rtc.yaml"
"$bin/rtc-manager/urs-rtc-manager" --space lab --naming "$naming" --host labpc --config "$work/rtc.yaml" \
  --ready-file "$work/rtc.ready" >"$work/rtc-manager.log" 2>&1 &
pids+=("$!")
wait_for 30 "urs-rtc-manager up" test -s "$work/rtc.ready"
"$bin/sam/urs-sam" --space lab --server "$server" --config "$root/services/sam/diagnostic.yaml" >"$work/sam.log" 2>&1 &
pids+=("$!")
"$bin/bridge/urs-bridge" --space lab --server "$server" --naming "$naming" --host labpc \
  --config "$root/deploy/lab/bridge.yaml" --ready-file "$work/bridge.ready" >"$work/bridge.log" 2>&1 &
pids+=("$!")
urs() { "$bin/cli/urs" --server "$server" "$@"; }
rtc() { "$bin/cli/urs" rtc --naming "$naming" "$@"; }
for service in robot1.navigation camera tts voice; do
  wait_for 20 "$service offered to CAMUS" bash -c "'$bin/cli/urs' --server $server ls $service | grep -q '^$service '"
done
wait_for 20 "diag offered to RT consumers" bash -c "'$bin/cli/urs' rtc --naming $naming ls labpc.host_cxt/camus_diag.rtc"
urs ls
rtc ls

step "both directions: an RT consumer calls the SAM's agent; the localizer's data port feeds CAMUS context"
rtc call labpc.host_cxt/camus_diag.rtc:diagnostic echo '{"text":"hello CAMUS, from an RT consumer"}'
wait_for 60 "a localizer pose in the context" bash -c "'$bin/cli/urs' --server $server context get robot1.pose"
urs context get robot1.pose

step "1a. square path at 500 mm/s, an RT consumer calling the robot RTC directly (time scale $scale)"
"$bin/lab/urs-lab" --out "$out" square --via rt --naming "$naming" --port labpc.host_cxt/Robot0.rtc:navigation \
  --label "a-rt-consumer" --domain "$domain" --time-scale "$scale"
step "1b. the same path driven by a CAMUS client through the bridge"
"$bin/lab/urs-lab" --out "$out" square --via camus --server "$server" --service robot1.navigation \
  --label "b-camus-through-bridge" --domain "$domain" --time-scale "$scale"
step "2. speed changes 200 -> 800 -> 500 -> 0 mm/s through the bridge"
"$bin/lab/urs-lab" --out "$out" speed --server "$server" --service robot1.navigation --domain "$domain" \
  --time-scale "$scale"
step "3. camera, image recognition, TTS and voice recognition RTCs used from CAMUS through the bridge"
"$bin/lab/urs-lab" --out "$out" speech-vision --server "$server" --camera camera --tts tts --voice voice

step "report ($out/experiments.md)"
"$bin/lab/urs-lab" --out "$out" report
