#!/usr/bin/env bash
# e2e (two hosts): two sites that pass no multicast, each its own network namespace with its own
# address on a veth link and a firewall that drops multicast, so DDS discovery can only be unicast:
#   site jp (10.77.0.1): omniNames, urs-rtc-manager with a Diagnostic RTC, bridge-jp
#   site kr (10.77.0.2): urs-camus-server, urs-sam with the diagnostic agent, bridge-kr
# First bridge-jp is a Fast DDS discovery server and bridge-kr its client, on a plain link; then
# both bridges are restarted with each other's address as an initial peer, on a link secured with
# DDS-Security (a federation PKI made by deploy/pki.sh; Fast DDS 2.9's discovery server and
# DDS-Security do not go together). Each time, from kr: jp's RTC is a CAMUS service that answers,
# its lifecycle state is in kr's context, and kr's agent answers from jp through the RTC bridge-jp
# made for it. A capture of the frames between the hosts (capture.py) holds the text of a call on
# the plain link, and none of it on the secured one. Needs root (ip netns, AF_PACKET); always
# removes the namespaces.
#   tests/e2e/two_hosts/run.sh [SOURCE_DIR [BUILD_DIR]]
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=${1:-$(cd "$here/../../.." && pwd)}
build=${2:-${URS_BUILD_DIR:-$root/build}}
bin=$build/services
test_name=e2e_two_hosts
source "$here/../steps.sh"

[[ $(id -u) -eq 0 ]] || die "needs root for ip netns (run as root, as CI does)"
command -v ip >/dev/null || die "ip (Debian: iproute2) is not installed"
command -v omniNames >/dev/null || die "omniNames (Debian: omniorb-nameserver) is not installed"
command -v nft >/dev/null || die "nft (Debian: nftables) is not installed"

tag=u$$
jp=urs-jp-$tag
kr=urs-kr-$tag
work=$(mktemp -d)
cleanup() {
  local rc=$?
  if [[ $rc -ne 0 || -n "$failed_step" ]]; then
    echo "==== step failed: ${failed_step:-setup}; logs:"
    for f in "$work"/*.log; do [[ -e "$f" ]] && { echo "---- $f"; tail -n 40 "$f"; }; done
  fi
  for ns in "$jp" "$kr"; do
    ip netns pids "$ns" 2>/dev/null | xargs -r kill -9 2>/dev/null
    ip netns del "$ns" 2>/dev/null
  done
  rm -rf "$work"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

step "two hosts: network namespaces $jp (10.77.0.1) and $kr (10.77.0.2), multicast dropped"
ip netns add "$jp" && ip netns add "$kr" || fail "ip netns add"
ip link add "veth-$tag-j" type veth peer name "veth-$tag-k" || fail "veth"
ip link set "veth-$tag-j" netns "$jp" && ip link set "veth-$tag-k" netns "$kr" || fail "veth into namespaces"
ip -n "$jp" addr add 10.77.0.1/24 dev "veth-$tag-j" && ip -n "$kr" addr add 10.77.0.2/24 dev "veth-$tag-k" || fail "addresses"
for ns in "$jp" "$kr"; do
  ip -n "$ns" link set lo up
  ip -n "$ns" link set dev "$(ip -n "$ns" -o link | awk -F': ' '/veth/{print $2}' | cut -d@ -f1)" multicast off up \
    || fail "link up in $ns"
  # Fast DDS sends multicast on a chosen interface (IP_MULTICAST_IF), whatever the routes say:
  # the firewall drops it both ways, as a site network that passes no multicast would.
  ip netns exec "$ns" nft -f - <<'NFT' || fail "nft in $ns"
table ip urs_no_multicast {
  chain out { type filter hook output priority 0; ip daddr 224.0.0.0/4 drop; }
  chain in { type filter hook input priority 0; ip daddr 224.0.0.0/4 drop; }
}
NFT
done
in_jp() { ip netns exec "$jp" "$@"; }
in_kr() { ip netns exec "$kr" "$@"; }

step "site jp: omniNames, urs-rtc-manager (Diagnostic), bridge-jp as a Fast DDS discovery server"
in_jp omniNames -start 2809 -datadir "$work" -logdir "$work" -ORBendPoint giop:tcp:10.77.0.1:2809 >"$work/naming.log" 2>&1 &
printf 'components:\n  - type: Diagnostic\n' >"$work/rtc.yaml"
eventually 10 in_jp bash -c 'exec 3<>/dev/tcp/10.77.0.1/2809' || fail "omniNames does not listen"
in_jp "$bin/rtc-manager/urs-rtc-manager" --space jp --naming 10.77.0.1:2809 --host jp1 --config "$work/rtc.yaml" \
  --listen 10.77.0.1:2810 --ready-file "$work/rtc.ready" >"$work/rtc-manager.log" 2>&1 &
eventually 20 test -e "$work/rtc.ready" || fail "urs-rtc-manager did not come up"
cat >"$work/jp-bridge.yaml" <<'EOF'
name: bridge-jp
rt_to_camus:
  poll_ms: 100
  providers: [{match: "*", name: "rt.{instance}"}]
dds:
  domain: 7
  lease_ms: 2000
  udp_only: true
  discovery: {listen: "10.77.0.1:11811"}
  state: {period_ms: 200}
EOF
in_jp "$bin/bridge/urs-bridge" --space jp --naming 10.77.0.1:2809 --listen 10.77.0.1:2811 --host jp-bridge \
  --config "$work/jp-bridge.yaml" --ready-file "$work/jp.ready" >"$work/bridge-jp.log" 2>&1 &
eventually 20 test -e "$work/jp.ready" || fail "bridge-jp did not come up"

step "site kr: urs-camus-server, urs-sam (diag), bridge-kr a client of jp's discovery server"
head -c 24 /dev/urandom | base64 >"$work/token"
in_kr "$bin/camus-server/urs-camus-server" --space kr --listen 10.77.0.2:7600 --data-dir "$work/camus" \
  --token-file "$work/token" --token-role operator --allow-plaintext-tokens >"$work/server.log" 2>&1 &  # a private test link: tokens in clear opted in
urs() { in_kr "$bin/cli/urs" --server 10.77.0.2:7600 --token-file "$work/token" --timeout-ms 3000 "$@"; }
eventually 10 urs ls >/dev/null 2>&1 || fail "urs-camus-server does not answer"
in_kr "$bin/sam/urs-sam" --space kr --server 10.77.0.2:7600 --token-file "$work/token" \
  --config "$root/services/sam/diagnostic.yaml" >"$work/sam.log" 2>&1 &
start_kr_bridge() {  # start_kr_bridge DISCOVERY_YAML_LINE
  cat >"$work/kr-bridge.yaml" <<EOF
name: bridge-kr
dds:
  domain: 7
  lease_ms: 2000
  udp_only: true
  $1
EOF
  rm -f "$work/kr.ready"
  # ip netns exec itself (not a function, which would run in a subshell): $! is the bridge.
  ip netns exec "$kr" "$bin/bridge/urs-bridge" --space kr --server 10.77.0.2:7600 --token-file "$work/token" \
    --config "$work/kr-bridge.yaml" --ready-file "$work/kr.ready" >"$work/bridge-kr.log" 2>&1 &
  kr_bridge=$!
  eventually 20 test -e "$work/kr.ready" || fail "bridge-kr did not come up"
}
start_kr_bridge 'discovery: {servers: ["10.77.0.1:11811"]}'

linked() {  # linked MARKER: what each check says of the link between the sites, as seen from both
  local marker=$1 t=$SECONDS
  listed() { urs ls jp/rt.Diagnostic0 2>/dev/null | grep -q '^jp/rt.Diagnostic0 '; }
  eventually 30 listed || fail "jp's Diagnostic RTC is not a service in kr: $(urs ls 2>&1)"
  say "jp/rt.Diagnostic0 listed in kr $((SECONDS - t)) s after bridge-kr started"
  out=$(urs call jp/rt.Diagnostic0 echo "{\"text\":\"$marker\"}") || fail "call from kr to jp's RTC failed"
  [[ "$out" == "{\"result\":\"$marker\"}" ]] || fail "the echo across hosts answered $out"
  state() { urs context get jp/component/jp1.host_cxt/Diagnostic0.rtc 2>/dev/null | grep -q '"state":"Inactive"'; }
  eventually 20 state || fail "jp's RTC state is not in kr's context: $(urs context ls 'jp/*' 2>&1)"
  bound() { in_jp "$bin/cli/urs" rtc --naming 10.77.0.1:2809 ls jp-bridge.host_cxt 2>/dev/null | grep -q kr_diag.rtc; }
  eventually 30 bound || fail "kr's diag is not an RTC in jp"
  out=$(in_jp "$bin/cli/urs" rtc --naming 10.77.0.1:2809 call jp-bridge.host_cxt/kr_diag.rtc:diagnostic echo \
    '{"text":"back across"}') || fail "call from jp to kr's agent failed"
  [[ "$out" == '{"result":"back across"}' ]] || fail "the echo back answered $out"
}

# capture NAME: every frame on kr's end of the link into $work/NAME.frames (raw), until
# stop_capture.
capture() {
  rm -f "$work/capture.ready"
  in_kr python3 "$here/capture.py" "veth-$tag-k" "$work/$1.frames" "$work/capture.ready" 2>"$work/capture.log" &
  capture_pid=$!
  eventually 10 test -e "$work/capture.ready" || fail "the capture did not start: $(cat "$work/capture.log")"
}
stop_capture() { kill "$capture_pid"; wait "$capture_pid" 2>/dev/null; }
# seen NAME MARKER: how many times MARKER is in the capture NAME.
seen() { grep -a -o -F "$2" "$work/$1.frames" | wc -l; }

step "through the discovery server: calls both ways and jp's state in kr"
capture plain
plain_marker="plain-$(head -c 6 /dev/urandom | od -An -tx1 | tr -d ' \n')"
linked "$plain_marker"
stop_capture
in_clear=$(seen plain "$plain_marker")
((in_clear > 0)) || fail "the capture of the plain link holds no '$plain_marker': it captured nothing useful"
say "plain link: the call's text is in the capture $in_clear times ($(stat -c %s "$work/plain.frames") bytes captured)"

step "both bridges again, each the other's initial peer, on a link secured with DDS-Security"
kill "$kr_bridge"; wait "$kr_bridge" 2>/dev/null
gone() { ! urs ls 'jp/*' 2>/dev/null | grep -q '^jp/'; }
eventually 15 gone || fail "jp's services stayed in kr without bridge-kr"
# The federation's PKI: a CA, the governance (encrypted), and one member per space, each granted
# calls to the other. Both sites read the same folder here; two real sites exchange only what
# docs/federation.md says.
pki=$work/pki
for args in "init $pki" "governance $pki" "member $pki jp --calls kr" "member $pki kr --calls jp"; do
  # shellcheck disable=SC2086
  "$root/deploy/pki.sh" $args >>"$work/pki.log" 2>&1 || fail "deploy/pki.sh $args: $(tail -n 3 "$work/pki.log")"
done
# bridge-jp is a discovery server: a unicast peer that runs the simple protocol cannot discover
# it, so jp's bridge too goes back to the simple protocol with kr's host as its initial peer.
sed -i "s|discovery: {listen: \"10.77.0.1:11811\"}|initial_peers: [10.77.0.2]\n  security: {pki: \"$pki\"}|" \
  "$work/jp-bridge.yaml"
pkill -f -- "--config $work/jp-bridge.yaml"
old_gone() { ! pgrep -f -- "--config $work/jp-bridge.yaml" >/dev/null; }
eventually 15 old_gone || fail "bridge-jp did not stop on SIGTERM"
rm -f "$work/jp.ready"
in_jp "$bin/bridge/urs-bridge" --space jp --naming 10.77.0.1:2809 --listen 10.77.0.1:2812 --host jp-bridge \
  --config "$work/jp-bridge.yaml" --ready-file "$work/jp.ready" >"$work/bridge-jp.log" 2>&1 &
eventually 20 test -e "$work/jp.ready" || fail "bridge-jp did not come back"
capture secured
start_kr_bridge "initial_peers: [10.77.0.1]
  security: {pki: \"$pki\"}"
secured_marker="secured-$(head -c 6 /dev/urandom | od -An -tx1 | tr -d ' \n')"
linked "$secured_marker"
stop_capture
grep -q "secured (DDS-Security" "$work/bridge-kr.log" || fail "bridge-kr does not say it joined a secured link: $(tail -n 5 "$work/bridge-kr.log")"
(($(seen secured "$secured_marker") == 0)) || fail "the call's text '$secured_marker' crossed the secured link in clear"
say "secured link: none of the call's text in the capture ($(stat -c %s "$work/secured.frames") bytes captured)"

failed_step=""
say "e2e_two_hosts: every step passed in $((SECONDS - t_start)) s"
