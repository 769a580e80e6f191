#!/usr/bin/env bash
# The main job: two ubiquitous robot spaces as containers, linked only by DDS (docs/deployment.md).
#   jp (RT-Middleware): omniNames, the robot + localizer RTCs, camera/diagnostic RTCs, bridge-jp
#   kr (CAMUS):         urs-camus-server, a SAM with the diagnostic, TTS and voice agents, bridge-kr
# Installs what is missing, builds the binaries and the images (from Debian packages only), brings
# both spaces up, then
#   1. a CAMUS client in kr drives jp's robot around the square path (through bridge-kr, DDS,
#      bridge-jp, CORBA) and writes its trace plot;
#   2. an RT consumer in jp makes kr's TTS speak and kr's voice recognition hear it (through the
#      RTCs bridge-jp made for them) and reads jp's camera;
#   3. shows the state the spaces share over DDS: jp's robot pose and RTC states in kr's context;
# and prints a summary. Each space's dashboard (urs-gateway, docs/dashboard.md) is on the host while
# the demo runs: its URLs are printed first, so the square path can be watched in kr's view of jp. Outputs in ${URS_DEMO_OUT:-build/demo}: experiments.md, square.svg, CSV.
# The spaces are taken down at the end unless URS_DEMO_KEEP=1 (then: cd compose; docker-compose ps).
# The local, single-machine demo of every piece is deploy/demo-local.sh.
set -euo pipefail
source "$(dirname "$0")/prepare.sh"
install_and_build "${URS_DEMO_NO_BUILD:-}"
out=${URS_DEMO_OUT:-$build/demo}
mkdir -p "$out"
rm -f "$out"/square-*.{csv,md,json} "$out"/speech-vision.*
"$root/deploy/images/build.sh"

if docker compose version >/dev/null 2>&1; then compose=(docker compose); else compose=(docker-compose); fi
project=${URS_DEMO_PROJECT:-urslink}
dc() { "${compose[@]}" -p "$project" -f "$root/compose/docker-compose.yml" "$@"; }
step() { printf '\n\033[1m== %s\033[0m\n' "$*"; }
finish() {
  local rc=$?
  if [[ $rc -ne 0 ]]; then echo "demo: failed (exit $rc); container logs:"; dc logs --no-color --tail=40 || true; fi
  if [[ -z "${URS_DEMO_KEEP:-}" ]]; then dc down -v -t 5 >/dev/null 2>&1 || true; fi
}
trap finish EXIT
healthy() {
  local ids; ids=$(dc ps -q)
  [[ -n "$ids" ]] && ! docker inspect -f '{{.State.Health.Status}}' $ids | grep -qv '^healthy$'
}
retry() {  # retry SECONDS COMMAND...
  local until=$((SECONDS + $1)); shift
  until "$@" >/dev/null 2>&1; do ((SECONDS < until)) || return 1; sleep 1; done
}
kr() { dc run --rm -T cli-kr "$@"; }
jp() { dc run --rm -T cli-jp "$@"; }
lab_in() {  # lab_in SPACE ARGS...: urs-lab in that space's client container, writing to $out
  local space=$1; shift
  dc run --rm -T --user "$(id -u):$(id -g)" -v "$out:/out" --entrypoint urs-lab "cli-$space" --out /out "$@"
}

step "two spaces up: jp (RT) and kr (CAMUS), linked only by DDS"
dc up -d
retry 180 healthy || { dc ps; echo "demo: the spaces did not become healthy" >&2; exit 1; }
dc ps
robot_listed() { kr ls 'jp/robot1.navigation' | grep -q '^jp/robot1.navigation '; }
retry 60 robot_listed || { echo "demo: jp's robot did not appear in kr" >&2; exit 1; }

host=$(hostname -f 2>/dev/null || hostname)
step "the dashboards (log in with the space's credential; URS_DEMO_KEEP=1 keeps them up afterwards)"
echo "kr: http://$host:${URS_KR_DASHBOARD_PORT:-8765}/  credential: the content of ${URS_KR_OPERATOR_TOKEN_FILE:-$root/compose/config/kr-operator.token} (kr's operators')"
echo "jp: http://$host:${URS_JP_DASHBOARD_PORT:-8766}/  credential: the content of ${URS_JP_TOKEN_FILE:-$root/compose/config/jp.token}"
echo "Foxglove / Lichtblick: Open connection -> Foxglove WebSocket -> the ws://...?session=... URL each dashboard shows after login"

step "kr sees jp's RT providers as CAMUS services, jp sees kr's agents as RTCs"
kr ls
jp rtc ls

step "1. a CAMUS client in kr drives jp's robot around the square path (500 mm/s, simulated time 4x)"
lab_in kr square --via camus --server camus-server:7600 --service jp/robot1.navigation --trace poll \
  --time-scale 4 --label kr-client-through-dds

step "2. an RT consumer in jp makes kr's TTS speak, kr's voice recognition hear it, and reads jp's camera"
sam=$(kr ls 'tts-*' | awk '/^tts-/{print substr($1, 5); exit}')
camera=$(jp rtc ls | awk '/host_cxt\/$/{context=$1} /Camera0\.rtc/{print context "Camera0.rtc"; exit}')
lab_in jp speech-vision --via rt --naming rtc-naming:2809 --text "go forward" \
  --tts "bridge-jp.host_cxt/kr_tts-$sam.rtc:texttospeech" \
  --voice "bridge-jp.host_cxt/kr_voice-$sam.rtc:voicerecognition" --camera "$camera:imagerecognition"

step "3. shared state over DDS: kr's context holds jp's robot pose and RTC lifecycle states"
kr context ls 'jp/*' | python3 -c 'import json, sys
for e in json.load(sys.stdin)["entries"]:
    print(e["key"].ljust(56), json.dumps(e["value"], sort_keys=True))'

step "summary ($out/experiments.md, trace plot $out/square.svg)"
lab_in kr report
