#!/usr/bin/env bash
# e2e (containers): builds the images (Docker's cache reuses what is unchanged), brings up the
# compose project (CAMUS space kr + RT space jp) under a private project name, waits until every
# container is healthy, then checks from client containers what a user would:
#   kr: `urs ls` lists this SAM's services, `urs call diag-<id> echo` answers, the TTS's audio of
#       "go forward" is recognised as "go forward" by the voice agent;
#   jp: `urs rtc ls -l` shows robot, localizer, camera and diagnostic RTCs, and `urs rtc act` of a
#       component in another container works (object references carry a reachable address);
#   scaling: --scale sam-host=2 rtc-manager=2 gives two distinct diag services, and the two
#       managers' components side by side in rtc-manager.host_cxt (Diagnostic0, Diagnostic1),
#       nothing overwritten;
#   restarts: a recreated naming service keeps its bindings; after the CAMUS server restarts both
#       SAMs and the bridge re-register.
#   between the spaces (only DDS crosses the `link` network): jp's RT providers are CAMUS services
#       in kr and kr's agents RTCs in jp; the demo scenario (a kr client drives jp's robot around
#       the square, waypoint errors asserted; a jp RT consumer makes kr's TTS speak and kr's voice
#       recognition hear it); a 921,600-byte image crosses whole; scaling jp's managers gives that
#       many services in kr; a killed bridge's space is unreachable from the other within the
#       lease (its services shown unreachable, calls refused at once naming it), every call in
#       flight gets an answer, and they work again with the bridge; cutting the link makes
#       cross-space calls fail fast naming the space, and reconnecting restores them;
#       shared state: jp's RTC lifecycle states and robot pose are entries of kr's context, and
#       leave it with jp's bridge; kr refuses a Planet client without its token; a call jp's
#       dds.export.callers grant nobody is refused with the reason and in jp's audit log.
#   intruders on the `link` network (containers of the bridge image running the host build's
#       tests/integration/bridge/catalog_peer, bind-mounted): a participant without security, one
#       with another CA's certificate for `jp`, and member `spy` (compose/make-pki.sh, granted no
#       calls and reads of kr only), each forging catalog entries as jp and kr, calling, and trying
#       to read the requests to jp and kr and to answer them. Neither bridge imports what they
#       write, the first two read nothing, the spy reads kr's catalog (granted) and nothing of jp's,
#       its own DDS refuses its writers in jp's and kr's partitions and its call endpoints, and
#       calls between the spaces go on; their reports are printed. A capture of the link network
#       during cross-space calls holds none of their text (a capture of jp's network, where the
#       CORBA request carries it in clear, holds it: the control).
#   the dashboards (headless Chromium, tests/integration/gateway/browser_test.py --url): kr's, logged
#       in with kr's operators' credential, lists every service of both spaces, sees jp's robot
#       driven around the square by the demo step, and calls jp's diagnostic echo from the form;
#       jp's activates and deactivates one of jp's components. Screenshots in
#       BUILD_DIR/artifacts/dashboard/{kr,jp}/.
# Always tears the project down (containers, networks, volumes); a failing step prints the logs.
#   tests/e2e/containers/run.sh [SOURCE_DIR [BUILD_DIR]]
# Environment: URS_COMPOSE (compose command, default `docker compose` when present, else
# docker-compose), URS_E2E_SKIP_IMAGE_BUILD=1 (use the urslink/*:dev images as they are).
# The dashboards are published on free host ports (URS_KR_DASHBOARD_PORT / URS_JP_DASHBOARD_PORT
# are chosen here, so a running demo on 8765/8766 does not clash).
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=${1:-$(cd "$here/../../.." && pwd)}
build=${2:-${URS_BUILD_DIR:-$root/build}}
test_name=e2e_containers
source "$here/../steps.sh"
source "$here/compose.sh"

# ---- prerequisites: fail loudly, never skip --------------------------------------------------
find_compose

for f in /usr/bin/chromium /usr/bin/chromedriver; do
  [[ -x $f ]] || die "$f is missing (Debian: apt-get install chromium chromium-driver); the dashboard step needs it"
done
/usr/bin/python3 -c 'import selenium' 2>/dev/null || die "python3-selenium is missing (Debian: apt-get install python3-selenium)"

project=urs-e2e-$$
compose_files=(-f "$root/compose/docker-compose.yml")
# Free host ports for the two dashboards (a demo may hold 8765/8766); read back with `dc port`.
export URS_KR_DASHBOARD_PORT=${URS_E2E_KR_DASHBOARD_PORT:-$(free_port)}
export URS_JP_DASHBOARD_PORT=${URS_E2E_JP_DASHBOARD_PORT:-$(free_port)}
while [[ $URS_JP_DASHBOARD_PORT == "$URS_KR_DASHBOARD_PORT" ]]; do URS_JP_DASHBOARD_PORT=$(free_port); done
# Prometheus too (compose's monitoring profile), on a free host port of its own.
export COMPOSE_PROFILES=monitoring
export URS_PROMETHEUS_PORT=${URS_E2E_PROMETHEUS_PORT:-$(free_port)}
while [[ $URS_PROMETHEUS_PORT == "$URS_KR_DASHBOARD_PORT" || $URS_PROMETHEUS_PORT == "$URS_JP_DASHBOARD_PORT" ]]; do
  URS_PROMETHEUS_PORT=$(free_port)
done
make_credentials

intruders=()  # containers of the intruder step (docker run, outside the compose project)
capture_pids=()  # the captures of the capture step (host processes)
teardown() {
  local rc=$? name
  if [[ $rc -ne 0 || -n "$failed_step" ]]; then
    report_project
    for name in "${intruders[@]}"; do
      echo "==== intruder $name"
      docker logs --tail=40 "$name" 2>&1 || true
    done
  fi
  ((${#intruders[@]})) && docker rm -f "${intruders[@]}" >/dev/null 2>&1
  ((${#capture_pids[@]})) && kill "${capture_pids[@]}" 2>/dev/null
  down_project
}
trap teardown EXIT
trap 'exit 130' INT TERM


tmp=$(mktemp -d)
trap 'teardown; rm -rf "$tmp"' EXIT

images rtc-naming camus-server sam-host rtc-manager cli bridge gateway prometheus
compose_up

# ---- kr: the CAMUS space ------------------------------------------------------------------------
step "kr: urs ls lists the SAM's services"
sam1=$(docker inspect -f '{{.Config.Hostname}}' "$(dc ps -q sam-host)")
out=$(kr ls) || fail "urs ls: $(cat "$tmp/cli.err")"
echo "$out"
# OWNER is the credential the SAM authenticated with (kr's one token: "space"); PEER its own name.
grep -qE "^diag-$sam1 +URS\.Diagnostic +space +sam@$sam1 +available" <<<"$out" || fail "diag-$sam1 missing"
grep -qE "^tts-$sam1 +URC\.TextToSpeech " <<<"$out" || fail "tts-$sam1 missing"
grep -qE "^voice-$sam1 +URC\.VoiceRecognition " <<<"$out" || fail "voice-$sam1 missing"

step "kr: urs call diag echo"
out=$(kr call "diag-$sam1" echo '{"text":"hello from a container"}') || fail "call: $(cat "$tmp/cli.err")"
echo "$out"
[[ "$out" == '{"result":"hello from a container"}' ]] || fail "unexpected echo reply: $out"

step "kr: the TTS's audio of 'go forward' is recognised (espeak-ng and pocketsphinx data in the image)"
wav=$(kr call "tts-$sam1" speak '{"text":"go forward"}' | python3 -c 'import json,sys; print(json.load(sys.stdin)["result"]["wav"])') \
  || fail "tts speak: $(cat "$tmp/cli.err")"
out=$(kr call "voice-$sam1" playBytes "{\"wave\":\"$wav\"}") || fail "voice playBytes: $(cat "$tmp/cli.err")"
echo "$out"
grep -q '"text":"go forward"' <<<"$out" || fail "not recognised as 'go forward': $out"

# ---- jp: the RT space ---------------------------------------------------------------------------
step "jp: urs rtc ls -l shows the device RTCs"
robot_host=$(docker inspect -f '{{.Config.Hostname}}' "$(dc ps -q rtc-robot)")
mgr1=$(docker inspect -f '{{.Config.Hostname}}' "$(dc ps -q rtc-manager)")
out=$(jp rtc ls -l) || fail "urs rtc ls: $(cat "$tmp/cli.err")"
echo "$out"
expect_rtc() { awk -v ctx="$1.host_cxt/" -v rtc="$2" -v state="$3" '
  /^[^ ]/ {in_ctx = ($1 == ctx)} in_ctx && $1 == rtc && $2 == state {found = 1} END {exit !found}' <<<"$out" \
  || fail "$1.host_cxt/$2 not $3"; }
expect_rtc "$robot_host" Robot0.rtc Active
expect_rtc "$robot_host" Localizer0.rtc Active
expect_rtc "$mgr1" Camera0.rtc Inactive
expect_rtc "$mgr1" Diagnostic0.rtc Inactive

step "jp: urs rtc act/deact reach a component in another container"
jp rtc act "$mgr1.host_cxt/Diagnostic0.rtc" >/dev/null || fail "rtc act: $(cat "$tmp/cli.err")"
out=$(jp rtc ls "$mgr1.host_cxt/Diagnostic0.rtc") || fail "rtc ls: $(cat "$tmp/cli.err")"
grep -q "Diagnostic0.rtc *Active" <<<"$out" || fail "Diagnostic0 not Active after act: $out"
jp rtc deact "$mgr1.host_cxt/Diagnostic0.rtc" >/dev/null || fail "rtc deact: $(cat "$tmp/cli.err")"

# ---- between the spaces --------------------------------------------------------------------------
lab_in() {  # urs-lab in a space's client container, writing to $tmp/out
  local space=$1; shift
  dc run --rm -T --user "$(id -u):$(id -g)" -v "$tmp/out:/out" --entrypoint urs-lab "cli-$space" --out /out "$@" \
    2>"$tmp/cli.err"
}
mkdir -p "$tmp/out"
step "link: jp's RT providers are services in kr, kr's agents are RTCs in jp"
eventually 60 jp_listed robot1.navigation || fail "jp/robot1.navigation not in kr: $(kr ls)"
eventually 30 jp_listed "Diagnostic0.diagnostic@$mgr1" || fail "jp's Diagnostic0 not in kr: $(kr ls)"
eventually 30 kr_bound "kr_tts-$sam1.rtc" || fail "kr's TTS not bound in jp: $(jp rtc ls)"
cross_space_echoes "hello"

step "link: the bridges and gateways joined it secured (DDS-Security, compose/make-pki.sh's members)"
for member in bridge-kr bridge-jp; do
  logs=$(dc logs "$member" 2>&1)  # whole: grep -q would end the pipe early (pipefail)
  [[ "$logs" == *"secured (DDS-Security"* ]] || fail "$member is not on a secured link: $(grep 'DDS domain' <<<"$logs")"
done

step "link: a call jp grants nobody is refused with the reason, and jp's bridge audits it"
# compose/config/jp-bridge.yaml: dds.export.callers lets nobody call robot1.localization (kr sees
# it), and dds.audit writes every call from kr to /var/lib/urs/bridge/calls.jsonl (jp-bridge volume).
eventually 30 jp_listed robot1.localization || fail "jp/robot1.localization not in kr: $(kr ls 'jp/*')"
kr call jp/robot1.localization getPose >/dev/null && fail "kr called jp/robot1.localization, which jp grants nobody"
refusal=$(grep '^urs:' "$tmp/cli.err")
echo "kr calls jp/robot1.localization: $refusal"
# kr's CLI authenticates as "space" (compose's token): its server names it, and jp judges kr/space.
[[ $refusal == *PERMISSION_DENIED* && $refusal == *"kr/space may not call jp/robot1.localization"* ]] \
  || fail "no refusal with the reason: $(cat "$tmp/cli.err")"
audited_refusal() {
  docker exec "$(dc ps -q bridge-jp)" cat /var/lib/urs/bridge/calls.jsonl >"$tmp/audit.jsonl" 2>/dev/null || return 1
  python3 - "$tmp/audit.jsonl" <<'PY'
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
refused = [l for l in lines if l["service"] == "robot1.localization" and l["status"] == "PERMISSION_DENIED"]
assert refused, lines[-3:]
r = refused[-1]
assert (r["caller_space"], r["caller"], r["space_verified"], r["operation"], r["reason"]) == \
    ("kr", "space", True, "getPose", "kr/space may not call jp/robot1.localization"), r
print("jp's audit log (dds.audit):", json.dumps(r))
PY
}
eventually 10 audited_refusal || fail "jp's audit log has no such refusal: $(tail -3 "$tmp/audit.jsonl")"

step "intruders on link: a plain participant, another CA's 'jp', member spy speaking as jp and kr"
# Three containers of the bridge image on the link network, each running catalog_peer (a test
# program of the host build, bind-mounted: it is no part of any image) with its report every
# second: the catalog entries it reads, its calls' outcomes, the requests to jp and kr it reads and
# the readers its replies to them match. Its lease is the bridges' (dds.lease_ms 3000): a reader
# asking for a shorter one would match none of their writers. Each writes catalog entries intruder.<name> as space jp
# and as space kr (its own catalog writer, as a forger would).
peer_bin=$build/tests/integration/bridge/catalog_peer
[[ -x $peer_bin ]] || fail "$peer_bin is not built (cmake --build $build --target catalog_peer)"
link_net=$(docker inspect -f '{{range $k, $v := .NetworkSettings.Networks}}{{$k}} {{end}}' "$(dc ps -q bridge-kr)" | tr ' ' '\n' | grep '_link$')
[[ -n "$link_net" ]] || fail "bridge-kr is on no link network"
pki_dir=${URS_PKI_DIR:-$root/compose/config/pki}
[[ -s $pki_dir/spy/permissions.p7s ]] || fail "$pki_dir holds no member spy (compose/make-pki.sh)"
# Another federation's CA, with the same name as compose's, and its member jp.
"$root/deploy/pki.sh" init "$tmp/rogue" --name "URSLink compose federation" >/dev/null \
  && "$root/deploy/pki.sh" governance "$tmp/rogue" >/dev/null \
  && "$root/deploy/pki.sh" member "$tmp/rogue" jp --calls kr >/dev/null || fail "deploy/pki.sh: the rogue CA"
intruder() {  # NAME [docker run option...] -- catalog_peer argument...
  local name=$project-intruder-$1 options=()
  shift
  while [[ $1 != -- ]]; do options+=("$1"); shift; done
  shift
  intruders+=("$name")
  docker run -d --name "$name" --network "$link_net" --user 10001:10001 --read-only --cap-drop ALL \
    --security-opt no-new-privileges:true --no-healthcheck -e LD_LIBRARY_PATH=/opt/urslink/lib \
    -v "$peer_bin:/opt/test/catalog_peer:ro" --entrypoint /opt/test/catalog_peer "${options[@]}" \
    "urslink/bridge:${URS_IMAGE_TAG:-dev}" --peers bridge-jp,bridge-kr --lease-ms 3000 --as jp,kr --snoop jp,kr "$@" >/dev/null \
    || fail "docker run $name"
}
intruder plain -- --call "kr/diag-$sam1" 0 jp +intruder.plain
intruder rogue -v "$tmp/rogue:/pki:ro" -- --pki /pki --member jp --call "kr/diag-$sam1" 0 jp +intruder.rogue
spy_mounts=()
for f in ca.pem governance.p7s crl.pem spy; do spy_mounts+=(-v "$pki_dir/$f:/pki/$f:ro"); done
intruder spy "${spy_mounts[@]}" -- --pki /pki --member spy --call "jp/Diagnostic0.diagnostic@$mgr1" 0 spy +intruder.spy
t=$SECONDS
# The spy is a member: both bridges read its entries, and take none of them as jp's or kr's.
refused_by() { dc logs "$1" >"$tmp/bridge.log" 2>&1; grep -q "a member proven as spy announced space $2's catalog entry $2/intruder.spy: ignored" "$tmp/bridge.log"; }
eventually 30 refused_by bridge-kr jp || fail "bridge-kr did not refuse spy's jp/intruder.spy: $(grep -i spy "$tmp/bridge.log")"
eventually 30 refused_by bridge-jp kr || fail "bridge-jp did not refuse spy's kr/intruder.spy: $(grep -i spy "$tmp/bridge.log")"
say "both bridges refused spy's entries $((SECONDS - t)) s after the intruders started"
calls_of() { docker logs "$1" 2>/dev/null | grep -c '^call '; }
three_calls() { local n; for n in "${intruders[@]}"; do (($(calls_of "$n") >= 3)) || return 1; done; }
eventually 40 three_calls || fail "an intruder did not try 3 calls: $(for n in "${intruders[@]}"; do echo "$n $(calls_of "$n")"; done)"
# The spaces keep working with the intruders on their link.
cross_space_echoes "intruders around"
say "cross-space calls kr -> jp and jp -> kr answered with the intruders on the link"
out=$(kr ls) || fail "urs ls: $(cat "$tmp/cli.err")"
grep -q intruder <<<"$out" && fail "kr imported an intruder's entry: $(grep intruder <<<"$out")"
out=$(jp rtc ls) || fail "urs rtc ls: $(cat "$tmp/cli.err")"
grep -q intruder <<<"$out" && fail "jp bound an intruder's entry: $(grep intruder <<<"$out")"
grep -q "kr_diag-$sam1.rtc" <<<"$out" || fail "kr's services left jp: $out"
echo "intruders' results (catalog_peer's reports):"
for name in "${intruders[@]}"; do
  docker logs "$name" >"$tmp/intruder.log" 2>&1
  who=${name##*-intruder-}
  # What it read of the spaces: the entries of every catalog report but its own (intruder.*).
  spaces_seen=$(grep '^seen ' "$tmp/intruder.log" | tr ' ' '\n' | grep '^[a-z]*/' | grep -v '/intruder\.' | sort -u | tr '\n' ' ')
  calls=$(grep '^call ' "$tmp/intruder.log" | sed 's/^call [^:]*: //' | sort | uniq -c | sed 's/^ *//' | tr '\n' ';')
  requests=$(grep -c '^request ' "$tmp/intruder.log")
  printf '  %-5s catalog entries of jp or kr it read: %s\n        calls: %s\n        requests reached it: %s\n' \
    "$who" "${spaces_seen:-none}" "$calls" "$requests"
  for topic in urs/rpc/jp/request urs/rpc/kr/request urs/rpc/jp/reply urs/rpc/kr/reply; do
    printf '        %s\n' "$(grep "^snoop $topic:" "$tmp/intruder.log" | tail -1)"
  done
  ((requests == 0)) || fail "$who got requests: $(grep '^request ' "$tmp/intruder.log")"
  # Never matched by a bridge on the calls' topics: refused by its own permissions, or unmatched.
  grep -E '^snoop .*: matched [1-9]|read [1-9]' "$tmp/intruder.log" && fail "$who reads calls or its replies reach a space"
  case $who in
    plain | rogue)  # not a member: discovers nobody of the link, reads nothing
      [[ -z $spaces_seen ]] || fail "$who read the spaces' catalog: $spaces_seen"
      grep -q '^seen ' "$tmp/intruder.log" || fail "$who printed no catalog report"
      grep '^call ' "$tmp/intruder.log" | grep -v ': UNAVAILABLE ' && fail "$who reached kr"
      ;;
    spy)  # a member granted reads of kr only and no calls: its own DDS refuses what it was not granted
      [[ $spaces_seen == *kr/* ]] || fail "spy, granted kr's partition, did not read kr's catalog: ${spaces_seen:-none}"
      [[ $spaces_seen == *jp/* ]] && fail "spy read jp's catalog, which it was not granted: $spaces_seen"
      for s in jp kr; do
        grep -q "^forge urs/catalog in partition $s: refused by its own DDS" "$tmp/intruder.log" ||
          fail "spy's DDS let it write in $s's partition: $(grep '^forge' "$tmp/intruder.log")"
      done
      grep '^call ' "$tmp/intruder.log" | grep -v ': PERMISSION_DENIED the permissions of space spy do not grant calls to space jp' \
        && fail "spy's call was not refused by its permissions"
      [[ $(grep -c '^snoop .*: refused$' "$tmp/intruder.log") -eq 4 ]] || fail "spy's permissions let it read or answer calls"
      ;;
  esac
done
docker rm -f "${intruders[@]}" >/dev/null 2>&1
intruders=()

step "link: a capture of the link network during cross-space calls holds none of their text"
# Two captures on the host (tests/e2e/two_hosts/capture.py, promiscuous on the bridge device of a
# compose network): the link's, and jp's as the control, where the same text crosses in clear in
# the CORBA request bridge-jp makes to the RTC. Found there, it must be nowhere on the link.
bridge_of() { local id; id=$(docker network inspect -f '{{.Id}}' "$1") && echo "br-${id:0:12}"; }
marker="urs-capture-marker-$$-$RANDOM"
capture_pids=()
for net in "$link_net" "${link_net%_link}_jp"; do
  dev=$(bridge_of "$net") || fail "no network $net"
  [[ -e /sys/class/net/$dev ]] || fail "network $net has no bridge device $dev on this host"
  rm -f "$tmp/$net.ready"
  python3 "$root/tests/e2e/two_hosts/capture.py" "$dev" "$tmp/$net.frames" "$tmp/$net.ready" 2>"$tmp/$net.capture.log" &
  capture_pids+=($!)
  eventually 10 test -e "$tmp/$net.ready" || fail "the capture of $net did not start: $(cat "$tmp/$net.capture.log")"
done
cross_space_echoes "$marker"
kill "${capture_pids[@]}"; wait "${capture_pids[@]}" 2>/dev/null || true
capture_pids=()
on_link=$(grep -c -a "$marker" "$tmp/$link_net.frames" || true)
on_jp=$(grep -c -a "$marker" "$tmp/${link_net%_link}_jp.frames" || true)
say "marker: $on_jp frames of jp's network ($(stat -c %s "$tmp/${link_net%_link}_jp.frames") bytes captured), $on_link of the link ($(stat -c %s "$tmp/$link_net.frames") bytes)"
((on_jp > 0)) || fail "the control capture of jp's network holds no marker: the capture sees nothing"
((on_link == 0)) || fail "the link carried a call's text in clear ($on_link frames)"
(($(stat -c %s "$tmp/$link_net.frames") > 0)) || fail "nothing captured on the link"

step "demo: a kr client drives jp's robot around the square (waypoint errors < 50 mm), kr's dashboard watching"
# kr's dashboard in headless Chromium, logged in with kr's operators' credential: every service of
# both spaces listed (kr's registry as `urs ls` shows it, and jp's catalog: the jp/... names),
# jp's robot seen driving the square below, an echo of jp's called from the form.
shots=$build/artifacts/dashboard
rm -rf "$shots/kr" "$shots/jp"
mkdir -p "$shots/kr" "$shots/jp"
kr_url="http://127.0.0.1:$(dc port gateway-kr 8765 | head -1 | sed 's/.*://')/"
jp_url="http://127.0.0.1:$(dc port gateway-jp 8765 | head -1 | sed 's/.*://')/"
kr ls --json >"$tmp/kr-ls.json" || fail "urs ls --json: $(cat "$tmp/cli.err")"
python3 - "$tmp/kr-ls.json" >"$tmp/kr-services" <<'PY' || fail "urs ls --json: unexpected output"
import json, sys
names = [s["name"] for s in json.load(open(sys.argv[1]))["services"]]
assert any(n.startswith("jp/") for n in names), names
for n in names:
    print("kr/" + n)              # kr's registry, jp's imported services included
    if n.startswith("jp/"):
        print(n)                  # jp's catalog over the link
PY
say "kr's dashboard at $kr_url expects $(wc -l <"$tmp/kr-services") services; jp's at $jp_url"
t_browser=$SECONDS
/usr/bin/python3 "$root/tests/integration/gateway/browser_test.py" --url "$kr_url" \
  --credential-file "${URS_KR_OPERATOR_TOKEN_FILE:-$root/compose/config/kr-operator.token}" --out "$shots/kr" \
  --spaces kr,jp --expect-services "$tmp/kr-services" --robot watch --ready-file "$tmp/browser.ready" \
  >"$tmp/browser-kr.log" 2>&1 &
browser_pid=$!
browser_ready() { [[ -e $tmp/browser.ready ]] || ! kill -0 "$browser_pid" 2>/dev/null; }
eventually 180 browser_ready || { kill "$browser_pid"; cat "$tmp/browser-kr.log"; fail "kr's dashboard not ready within 180 s"; }
[[ -e $tmp/browser.ready ]] || { wait "$browser_pid"; cat "$tmp/browser-kr.log"; fail "kr's dashboard: $(tail -1 "$tmp/browser-kr.log")"; }
lab_in kr square --via camus --server camus-server:7600 --service jp/robot1.navigation --trace poll \
  --time-scale 4 --label kr >/dev/null || { kill "$browser_pid"; fail "square path: $(cat "$tmp/cli.err")"; }
wait "$browser_pid"; browser_rc=$?
cat "$tmp/browser-kr.log"
((browser_rc == 0)) || fail "kr's dashboard in Chromium (screenshots in $shots/kr)"
say "kr's dashboard checked in $((SECONDS - t_browser)) s (square included); screenshots: $(ls "$shots"/kr/*.png | tr '\n' ' ')"
python3 - "$tmp/out/square-kr.json" <<'PY' || fail "square path: waypoint errors"
import json, sys
run = json.load(open(sys.argv[1]))
legs = [(l["x"], l["y"], l["error_mm"]) for l in run["legs"]]
print("waypoints:", legs)
assert [(x, y) for x, y, _ in legs] == [(1.5, 1.0), (1.5, 3.0), (5.0, 3.0), (5.0, 1.0), (1.5, 1.0)]
assert all(e < 50 for _, _, e in legs)
PY

step "state: jp's robot pose and RTC lifecycle states are in kr's context (shared over DDS)"
robot_state() {
  kr context ls 'jp/component/*' >"$tmp/components.json" || return 1
  python3 - "$tmp/components.json" <<'PY'
import json, sys
text = open(sys.argv[1]).read()
entries = [json.loads(line) for line in text.splitlines() if line.strip()]
entries = entries[0]["entries"] if len(entries) == 1 and "entries" in entries[0] else entries
robots = [e for e in entries if e["key"].endswith("/Robot0.rtc")]
assert robots and robots[0]["value"]["state"] == "Active" and robots[0]["origin"] == "dds:jp", robots
PY
}
eventually 30 robot_state || fail "jp's Robot0 is not Active in kr's context: $(cat "$tmp/components.json")"
robot_pose() {
  kr context get jp/pose/robot1 >"$tmp/pose.json" || return 1
  python3 - "$tmp/pose.json" <<'PY'
import json, sys
pose = json.load(open(sys.argv[1]))["value"]
print("jp/pose/robot1 in kr:", pose)
assert abs(pose["x"] - 1.5) < 0.2 and abs(pose["y"] - 1.0) < 0.2, pose  # back where the square ends
PY
}
eventually 30 robot_pose || fail "jp's robot pose is not in kr's context: $(cat "$tmp/pose.json")"

step "jp's dashboard: a component of jp activated and deactivated, a call from the form"
# jp has no CAMUS server: its gateway compares the login with its credential (secret jp-token).
t=$SECONDS
/usr/bin/python3 "$root/tests/integration/gateway/browser_test.py" --url "$jp_url" \
  --credential-file "${URS_JP_TOKEN_FILE:-$root/compose/config/jp.token}" --out "$shots/jp" \
  --spaces jp,kr --robot none --must-activate --component "$mgr1.host_cxt/Diagnostic0.rtc" >"$tmp/browser-jp.log" 2>&1
browser_rc=$?
cat "$tmp/browser-jp.log"
((browser_rc == 0)) || fail "jp's dashboard in Chromium (screenshots in $shots/jp)"
say "jp's dashboard checked in $((SECONDS - t)) s; screenshots: $(ls "$shots"/jp/*.png | tr '\n' ' ')"

step "kr: a Planet client without the space's token is refused"
dc run --rm -T -e URS_TOKEN_FILE= cli-kr ls >/dev/null 2>"$tmp/cli.err" && fail "a client without the token was let in"
grep -q UNAUTHENTICATED "$tmp/cli.err" || fail "no clear refusal: $(cat "$tmp/cli.err")"

step "demo: a jp RT consumer makes kr's TTS speak and kr's voice recognition hear it"
camera=$(jp rtc ls | awk -v ctx="$mgr1.host_cxt/" '/^[^ ]/{c=$1} c == ctx && /Camera0\.rtc/{print ctx "Camera0.rtc"}')
lab_in jp speech-vision --via rt --naming rtc-naming:2809 --text "go forward" \
  --tts "bridge-jp.host_cxt/kr_tts-$sam1.rtc:texttospeech" --voice "bridge-jp.host_cxt/kr_voice-$sam1.rtc:voicerecognition" \
  --camera "$camera:imagerecognition" >/dev/null || fail "speech-vision: $(cat "$tmp/cli.err")"
python3 - "$tmp/out/speech-vision.json" <<'PY' || fail "speech-vision: wrong results"
import json, sys
run = json.load(open(sys.argv[1]))
print("heard:", run["heard"], "markers:", run["markers"])
assert run["heard"] == "go forward"
assert sorted(run["markers"]) == ["urs:marker:1@6.5,1.0", "urs:marker:2@6.5,3.0"]
PY

step "a 921,600-byte image crosses from jp to kr whole"
kr call "jp/Camera0.imagerecognition@$mgr1" openCamera '{"device":0}' >/dev/null || fail "openCamera: $(cat "$tmp/cli.err")"
kr call "jp/Camera0.imagerecognition@$mgr1" captureImage '{"encoding":"IMAGE_ENCODING_RAW_RGB8"}' >"$tmp/image.json" \
  || fail "captureImage: $(cat "$tmp/cli.err")"
python3 - "$tmp/image.json" <<'PY' || fail "the image did not cross whole"
import base64, json, sys
image = json.load(open(sys.argv[1]))["result"]
data = base64.b64decode(image["data"])
print("image:", image["format"], len(data), "bytes")
assert len(data) == 921600 == image["format"]["width"] * image["format"]["height"] * 3
PY

# ---- monitoring ---------------------------------------------------------------------------------
step "Prometheus scrapes every program of both spaces; each hop's call counter rose by the calls made"
# The value of a PromQL query through Prometheus's HTTP API (the sum of its series; 0 if none).
prom() {
  python3 - "$URS_PROMETHEUS_PORT" "$1" <<'PY'
import json, sys, urllib.parse, urllib.request
port, query = sys.argv[1], sys.argv[2]
url = "http://127.0.0.1:%s/api/v1/query?query=%s" % (port, urllib.parse.quote(query))
with urllib.request.urlopen(url, timeout=5) as answer:
    data = json.load(answer)
assert data["status"] == "success", data
print("%g" % sum(float(series["value"][1]) for series in data["data"]["result"]))
PY
}
# kr: camus-server, sam-host, bridge-kr, gateway-kr; jp: rtc-robot, rtc-manager, bridge-jp, gateway-jp.
all_up() { [[ $(prom 'count(up == 1)' 2>/dev/null) == 8 && $(prom 'count(up == 0)' 2>/dev/null) == 0 ]]; }
eventually 60 all_up || fail "not every program is an up target: $(prom 'count(up == 1)') up, $(prom 'count(up == 0)') down"
say "8 targets up, none down"
hops=(
  'urslink_served_calls_total{instance="camus-server:9600",via="planet",service="jp/robot1.navigation",operation="getPosition",status="OK"}'
  'urslink_bridge_calls_total{instance="bridge-kr:9600",service="jp/robot1.navigation",operation="getPosition",status="OK"}'
  'urslink_served_calls_total{instance="bridge-jp:9600",via="dds",service="robot1.navigation",operation="getPosition",status="OK"}'
  'urslink_served_calls_total{instance="rtc-robot:9600",via="corba",operation="getPosition",status="OK"}'
)
before=()
for q in "${hops[@]}"; do before+=("$(prom "$q")"); done
calls=5
for ((i = 0; i < calls; ++i)); do
  kr call jp/robot1.navigation getPosition >/dev/null || fail "getPosition: $(cat "$tmp/cli.err")"
done
rose() {
  local i
  for i in "${!hops[@]}"; do
    [[ $(prom "${hops[$i]}") == $(awk -v b="${before[$i]}" -v n=$calls 'BEGIN {printf "%g", b + n}') ]] || return 1
  done
}
eventually 60 rose || {
  for i in "${!hops[@]}"; do echo "${hops[$i]}: ${before[$i]} -> $(prom "${hops[$i]}")"; done
  fail "a hop's call counter did not rise by the $calls calls made"
}
say "each of the 4 hops counted the $calls calls (camus-server, bridge-kr, bridge-jp, rtc-robot)"

# ---- scaling ------------------------------------------------------------------------------------
step "scale: sam-host=2 rtc-manager=2"
t=$SECONDS
dc up -d --scale sam-host=2 --scale rtc-manager=2 >"$tmp/up.log" 2>&1 || { cat "$tmp/up.log"; fail "scale up failed"; }
wait_healthy 90
say "scaled and healthy in $((SECONDS - t)) s"
diag_services() { kr ls | awk '$1 ~ /^diag-/ && $5 == "available" {print $1, $4}'; }
two_diags() { [[ $(diag_services | sort -u | wc -l) -eq 2 ]]; }
eventually 30 two_diags || fail "expected 2 diag services, got: $(diag_services | tr '\n' ';')"
diags=$(diag_services)
echo "$diags"
[[ $(awk '{print $1}' <<<"$diags" | sort -u | wc -l) -eq 2 && $(awk '{print $2}' <<<"$diags" | sort -u | wc -l) -eq 2 ]] \
  || fail "the two diag services are not distinct: $diags"
for d in $(awk '{print $1}' <<<"$diags"); do
  out=$(kr call "$d" echo "{\"text\":\"$d\"}") || fail "call $d: $(cat "$tmp/cli.err")"
  [[ "$out" == "{\"result\":\"$d\"}" ]] || fail "$d answered $out"
done
out=$(jp rtc ls) || fail "urs rtc ls: $(cat "$tmp/cli.err")"
echo "$out"
contexts=$(awk '/^[^ ].*\.host_cxt\/$/' <<<"$out" | tr '\n' ' ')
diag_rtcs=$(awk '/^[^ ]/{c=$1} c == "rtc-manager.host_cxt/" && /^  Diagnostic[01]\.rtc/' <<<"$out" | wc -l)
[[ $contexts == "bridge-jp.host_cxt/ rtc-manager.host_cxt/ rtc-robot.host_cxt/ " && $diag_rtcs -eq 2 ]] \
  || fail "expected the contexts bridge-jp, rtc-manager and rtc-robot, and Diagnostic0 and Diagnostic1 in rtc-manager, got $contexts and $diag_rtcs"
grep -q unreachable <<<"$out" && fail "a binding is unreachable"
cameras() { kr ls 'jp/Camera*' | awk '$1 ~ /^jp\/Camera[01]\.imagerecognition@rtc-manager$/ && $5 == "available"' | wc -l; }
two_cameras() { [[ $(cameras) -eq 2 ]]; }
eventually 30 two_cameras || fail "scaled jp managers: expected 2 cameras in kr, got: $(kr ls 'jp/*')"

# ---- the naming service is recreated: its bindings are kept (volume, fixed host name) -------------
step "jp: rtc-naming recreated, bindings kept and reachable"
t=$SECONDS
dc up -d --force-recreate --no-deps rtc-naming >"$tmp/up.log" 2>&1 || { cat "$tmp/up.log"; fail "recreate failed"; }
wait_healthy 60
out=$(jp rtc ls) || fail "urs rtc ls: $(cat "$tmp/cli.err")"
echo "$out"
[[ $(grep -cE "Diagnostic[01].rtc" <<<"$out") -eq 2 && $(grep -c "Robot0.rtc *Active" <<<"$out") -eq 1 ]] \
  || fail "bindings lost after the naming service was recreated"
grep -q unreachable <<<"$out" && fail "a binding is unreachable after the naming service was recreated"
say "naming service back with its bindings in $((SECONDS - t)) s"

# ---- the CAMUS server restarts: the SAMs re-register ----------------------------------------------
step "kr: camus-server restart, both SAMs re-register"
t=$SECONDS
dc restart -t 5 camus-server >/dev/null 2>&1 || fail "restart failed"
eventually 45 two_diags || fail "after the restart: $(diag_services | tr '\n' ';')"
say "both diag services back $((SECONDS - t)) s after the restart"
eventually 45 jp_listed robot1.navigation || fail "bridge-kr did not register jp's services again: $(kr ls)"
say "jp's services registered again by bridge-kr $((SECONDS - t)) s after the restart"
wait_healthy 60

# ---- faults between the spaces -------------------------------------------------------------------
step "bridge-jp killed: calls in flight are answered, jp is unreachable from kr within the lease"
diag_jp="jp/Diagnostic0.diagnostic@$mgr1"
for i in 1 2 3; do
  ( dc run --rm -T cli-kr call "$diag_jp" sleep '{"ms":4000}' --deadline-ms 8000 >/dev/null 2>"$tmp/inflight$i.err"
    echo $? >"$tmp/inflight$i.rc" ) &
done
sleep 1.5
t=$SECONDS
docker kill "$(dc ps -q bridge-jp)" >/dev/null || fail "docker kill bridge-jp"
wait
for i in 1 2 3; do
  rc=$(cat "$tmp/inflight$i.rc")
  reason=$(grep '^urs:' "$tmp/inflight$i.err")
  echo "call $i in flight: exit $rc: $reason"
  [[ ($rc -eq 1 || $rc -eq 3) && -n "$reason" ]] || fail "call $i in flight was not answered with an error (exit $rc)"
done
# Held (dds.hold_lost_ms, 30 s): listed as unreachable, each call refused at once naming the space.
unreachable() { kr ls 'jp/robot1.navigation' | grep '^jp/robot1.navigation ' | grep -q unreachable; }
eventually 15 unreachable || fail "jp's services not shown unreachable in kr: $(kr ls 'jp/*')"
say "jp unreachable from kr $((SECONDS - t)) s after the kill (lease 3 s)"
state_gone() { ! kr context ls 'jp/component/*' | grep -q Robot0; }
eventually 15 state_gone || fail "jp's component states still in kr: $(kr context ls 'jp/component/*')"
kr call jp/robot1.navigation getPosition >/dev/null && fail "a call to an unreachable space succeeded"
grep -q 'UNAVAILABLE.*space jp is unreachable' "$tmp/cli.err" || fail "no clear error: $(cat "$tmp/cli.err")"
dc start bridge-jp >/dev/null 2>&1 || fail "restart bridge-jp"
jp_calls() { kr call jp/robot1.navigation getPosition >/dev/null && ! unreachable; }
eventually 60 jp_calls || fail "jp's services did not come back: $(cat "$tmp/cli.err"); $(kr ls 'jp/*')"
say "back $((SECONDS - t)) s after the kill"

step "link cut: cross-space calls fail fast with a reason, and work again once reconnected"
link=$(docker inspect -f '{{range $k, $v := .NetworkSettings.Networks}}{{$k}} {{end}}' "$(dc ps -q bridge-kr)" | tr ' ' '\n' | grep '_link$')
[[ -n "$link" ]] || fail "bridge-kr is on no link network"
docker network disconnect "$link" "$(dc ps -q bridge-kr)" || fail "disconnect"
t=$SECONDS
eventually 20 unreachable || fail "jp's services not shown unreachable with the link cut: $(kr ls 'jp/*')"
say "cut noticed in $((SECONDS - t)) s"
t0=$SECONDS
kr call jp/robot1.navigation getPosition --deadline-ms 10000 >/dev/null && fail "a cross-space call succeeded with the link cut"
(( SECONDS - t0 < 5 )) || fail "the call with the link cut took $((SECONDS - t0)) s"
echo "with the link cut: $(cat "$tmp/cli.err")"
grep -q 'UNAVAILABLE.*space jp is unreachable' "$tmp/cli.err" || fail "the refusal does not name the space"
docker network connect "$link" "$(dc ps -q bridge-kr)" || fail "reconnect"
t=$SECONDS
eventually 60 jp_calls || fail "jp's services did not come back after reconnecting: $(cat "$tmp/cli.err"); $(kr ls 'jp/*')"
say "calls across spaces work again $((SECONDS - t)) s after reconnecting"
eventually 30 robot_state || fail "jp's component states did not come back to kr's context: $(cat "$tmp/components.json")"
say "jp's shared state back in kr $((SECONDS - t)) s after reconnecting"

failed_step=""
say "e2e_containers: every step passed in $((SECONDS - t_start)) s"
