#!/usr/bin/env bash
# e2e (containers, the link over TCP): the compose spaces with compose/docker-compose.tcp.yml over
# docker-compose.yml, under a private project name. bridge-jp listens on TCP 7400 at its fixed
# address on `link` (10.213.47.10), bridge-kr connects out to it, and nothing of the link is UDP.
# Checks:
#   the TCP variant's bridge configurations equal the UDP ones but for the link's transport;
#   each bridge and gateway logs that it joined the link over TCP (listening or connecting) and
#       secured (DDS-Security);
#   jp's services are imported in kr and kr's in jp, and an echo crosses each way (`urs call jp/...`
#       in kr, `urs rtc call .../kr_diag-<id>.rtc` in jp): fails when the spaces do not link (the
#       connecting bridge joins again after 20 s without meeting anyone: 90 s are given);
#   the link is that one connection: bridge-kr holds exactly one established TCP connection, to
#       10.213.47.10:7400, bridge-jp exactly one from bridge-kr on its port 7400, and kr's side of
#       the link (bridge-kr, gateway-kr, bridge-jp, gateway-jp) has no UDP socket on a port of DDS
#       domain 0 (7400-7649), so nothing of the link is UDP: bridge-jp and gateway-jp load the
#       images' fastdds-udp.xml (for jp's devices domain, 7650 and up), whose UDP transport the
#       link's participant does not take.
# Uses the images e2e_containers builds (deploy/images/build.sh: Docker's cache, seconds when they
# are there). Always tears the project down; a failing step prints the logs.
#   tests/e2e/containers/tcp.sh [SOURCE_DIR [BUILD_DIR]]
# Environment: URS_COMPOSE, URS_E2E_SKIP_IMAGE_BUILD=1 (as run.sh).
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=${1:-$(cd "$here/../../.." && pwd)}
build=${2:-${URS_BUILD_DIR:-$root/build}}
test_name=e2e_containers_tcp
source "$here/../steps.sh"
source "$here/compose.sh"

listener=10.213.47.10  # bridge-jp on `link` (compose/docker-compose.tcp.yml)
port=7400

find_compose
project=urs-e2e-tcp-$$
compose_files=(-f "$root/compose/docker-compose.yml" -f "$root/compose/docker-compose.tcp.yml")
export URS_KR_DASHBOARD_PORT=$(free_port)
export URS_JP_DASHBOARD_PORT=$(free_port)
while [[ $URS_JP_DASHBOARD_PORT == "$URS_KR_DASHBOARD_PORT" ]]; do URS_JP_DASHBOARD_PORT=$(free_port); done
make_credentials

tmp=$(mktemp -d)
teardown() {
  [[ -n "$failed_step" ]] && report_project
  down_project
  rm -rf "$tmp"
}
trap teardown EXIT
trap 'exit 130' INT TERM

step "the TCP variant's bridge configurations are the UDP ones but for the link's transport"
python3 - "$root/compose/config" <<'PY' || fail "a *-bridge-tcp.yaml differs from its *-bridge.yaml beyond dds.transport, tcp, udp_only and initial_peers"
import sys, yaml
folder = sys.argv[1]
for space in ("jp", "kr"):
    udp, tcp = (yaml.safe_load(open(f"{folder}/{space}-bridge{suffix}.yaml")) for suffix in ("", "-tcp"))
    assert tcp["dds"].get("transport") == "tcp", f"{space}-bridge-tcp.yaml: dds.transport is not tcp"
    for config in (udp, tcp):
        for key in ("transport", "tcp", "udp_only", "initial_peers"):
            config["dds"].pop(key, None)
    assert udp == tcp, f"{space}: {udp} != {tcp}"
PY

images rtc-naming camus-server sam-host rtc-manager cli bridge gateway
compose_up

step "each bridge and gateway joined the link over TCP, secured"
expect_log() {  # SERVICE TEXT
  local logs
  logs=$(dc logs "$1" 2>&1)  # whole: grep -q would end the pipe early (pipefail)
  [[ "$logs" == *"$2"* ]] || fail "$1 does not log '$2': $(grep 'dds:' <<<"$logs")"
}
expect_log bridge-jp "dds: the link over TCP: listening on port $port, announced at $listener:$port"
expect_log bridge-kr "dds: the link over TCP: connecting to $listener:$port (not listening)"
for member in gateway-kr gateway-jp; do
  expect_log "$member" "dds: the link over TCP: connecting to $listener:$port (not listening)"
done
for member in bridge-kr bridge-jp; do
  expect_log "$member" "secured (DDS-Security"
done

step "link over TCP: jp's services are in kr, kr's agents are RTCs in jp, an echo crosses each way"
sam1=$(docker inspect -f '{{.Config.Hostname}}' "$(dc ps -q sam-host)")
mgr1=$(docker inspect -f '{{.Config.Hostname}}' "$(dc ps -q rtc-manager)")
t=$SECONDS
eventually 90 jp_listed "Diagnostic0.diagnostic@$mgr1" || fail "jp's Diagnostic0 not in kr: $(kr ls)"
say "jp's services in kr $((SECONDS - t)) s after the containers were healthy"
eventually 30 kr_bound "kr_diag-$sam1.rtc" || fail "kr's diag not bound in jp: $(jp rtc ls)"
cross_space_echoes "over TCP"
say "an echo crossed each way"

step "the link is one TCP connection from bridge-kr to $listener:$port; no member of it has UDP of DDS domain 0"
# The sockets of a container's network namespace (/proc/net/*): TCP state 01 is ESTABLISHED.
sockets() {  # SERVICE -> lines "tcp|udp STATE LOCAL_IP:PORT REMOTE_IP:PORT"
  docker exec "$(dc ps -q "$1")" cat /proc/net/tcp /proc/net/udp >"$tmp/net" 2>&1 || return 1
  python3 - "$tmp/net" <<'PY'
import socket, struct, sys
def address(text):
    ip, port = text.split(":")
    return "%s:%d" % (socket.inet_ntoa(struct.pack("<I", int(ip, 16))), int(port, 16))
kind = None
for line in open(sys.argv[1]):
    fields = line.split()
    if fields[0] == "sl":
        kind = "udp" if kind == "tcp" else "tcp"  # /proc/net/tcp first, then /proc/net/udp
        continue
    print(kind, fields[3], address(fields[1]), address(fields[2]))
PY
}
kr_ip=$(docker inspect -f '{{range $name, $net := .NetworkSettings.Networks}}{{$name}} {{$net.IPAddress}}{{"\n"}}{{end}}' \
          "$(dc ps -q bridge-kr)" | awk '$1 ~ /_link$/ {print $2}')
[[ -n "$kr_ip" ]] || fail "bridge-kr has no address on the link network"
sockets bridge-kr >"$tmp/bridge-kr.sockets" || fail "the sockets of bridge-kr: $(cat "$tmp/net")"
for member in bridge-jp gateway-kr gateway-jp; do
  sockets "$member" >"$tmp/$member.sockets" || fail "the sockets of $member: $(cat "$tmp/net")"
done
kr_out=$(awk '$1 == "tcp" && $2 == "01" && $4 ~ /:7400$/' "$tmp/bridge-kr.sockets")
jp_in=$(awk -v from="$kr_ip:" -v to="$listener:$port" '$1 == "tcp" && $2 == "01" && $3 == to && index($4, from) == 1' "$tmp/bridge-jp.sockets")
echo "bridge-kr ($kr_ip) connects: ${kr_out:-nothing}"
echo "bridge-jp accepts from it: ${jp_in:-nothing}"
[[ $(grep -c . <<<"$kr_out") == 1 && $kr_out == *" $listener:$port" ]] \
  || fail "bridge-kr: expected one established connection to $listener:$port, got: ${kr_out:-none}"
[[ $(grep -c . <<<"$jp_in") == 1 ]] || fail "bridge-jp: expected one connection from $kr_ip on $port, got: ${jp_in:-none}"
dds_udp() { awk '$1 == "udp" {split($3, a, ":"); if (a[2] >= 7400 && a[2] <= 7649) print}' "$1"; }
for member in bridge-kr gateway-kr bridge-jp gateway-jp; do
  [[ -z "$(dds_udp "$tmp/$member.sockets")" ]] || fail "$member has UDP sockets of DDS domain 0: $(dds_udp "$tmp/$member.sockets")"
done

failed_step=""
say "$test_name: every step passed in $((SECONDS - t_start)) s"
