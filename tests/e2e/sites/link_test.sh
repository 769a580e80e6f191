#!/usr/bin/env bash
# e2e (sites): two spaces linked over TCP only (dds.transport: tcp, docs/sites.md) through two
# NAT routers and a bad path (wan.sh: 40 ms each way, 1 % loss), with the real programs:
#   site a, jp: omniNames, urs-rtc-manager with a Diagnostic RTC, bridge-jp listening on TCP 7400
#               and announcing router a's public address;
#   site b, kr: urs-camus-server, urs-sam with the diagnostic agent, bridge-kr connecting out to
#               router a's public address (router b passes only TCP out, nothing in).
# Checked, in order:
#   1. router a not forwarding 7400: kr never sees jp;
#   2. the port forwarded: the link comes up by itself (no restart); jp's RTC is a service in kr,
#      kr's agent an RTC in jp, calls pass both ways, 921,600-byte replies included, and jp's RTC
#      state is in kr's context;
#   3. the path cut for 20 s (both sides drop each other), then restored: everything passes again,
#      from the same processes;
#   4. router a forwarding public port 443 to 7400 instead: bridge-jp announcing 443
#      (tcp.public IP:443), bridge-kr connecting to 443, the link comes up and calls pass both ways.
# Needs root (ip netns, iptables, NFQUEUE); always removes its namespaces.
#   tests/e2e/sites/link_test.sh [SOURCE_DIR [BUILD_DIR]]
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=${1:-$(cd "$here/../../.." && pwd)}
build=${2:-${URS_BUILD_DIR:-$root/build}}
bin=$build/services
tools=$build/tests/e2e/sites
test_name=e2e_sites_link
source "$here/../steps.sh"
source "$here/wan.sh"
source "$here/jp_site.sh"

[[ $(id -u) -eq 0 ]] || die "needs root for ip netns (run as root, as CI does)"
command -v iptables >/dev/null || die "iptables (Debian: iptables) is not installed"
command -v omniNames >/dev/null || die "omniNames (Debian: omniorb-nameserver) is not installed"
[[ -x "$tools/wan-delay" ]] || die "$tools/wan-delay is not built"
for program in bridge/urs-bridge camus-server/urs-camus-server sam/urs-sam rtc-manager/urs-rtc-manager cli/urs; do
  [[ -x "$bin/$program" ]] || die "$bin/$program is not built"
done

wan_test_begin

step "two sites behind NAT, 40 ms each way and 1 % loss; nothing forwarded yet"
wan_up "l$$" "$tools/wan-delay" || fail "wan_up"
a=$WAN_A_LAN
b=$WAN_B_LAN

step "site a (jp): omniNames, urs-rtc-manager (Diagnostic), bridge-jp listening on TCP 7400"
jp_rt_up || fail "omniNames or urs-rtc-manager did not come up"
start_jp_bridge() {  # start_jp_bridge PUBLIC: bridge-jp listening on 7400, announced at PUBLIC
  jp_bridge_up "$1" "state: {period_ms: 200}" || fail "bridge-jp did not come up"
}
start_jp_bridge "$WAN_A_PUBLIC"

step "site b (kr): urs-camus-server, urs-sam (diag), bridge-kr connecting to $WAN_A_PUBLIC:7400"
head -c 24 /dev/urandom | base64 >"$work/token"
ip netns exec "$WAN_NS_B" "$bin/camus-server/urs-camus-server" --space kr --listen "$b:7600" --data-dir "$work/camus" \
  --token-file "$work/token" --token-role operator --allow-plaintext-tokens >"$work/server.log" 2>&1 &  # a test's private network
urs() { in_b "$bin/cli/urs" --server "$b:7600" --token-file "$work/token" --timeout-ms 10000 "$@"; }
rtc_call() { in_a "$bin/cli/urs" rtc --naming "$a:2809" call "$@"; }
eventually 10 urs ls >/dev/null 2>&1 || fail "urs-camus-server does not answer"
ip netns exec "$WAN_NS_B" "$bin/sam/urs-sam" --space kr --server "$b:7600" --token-file "$work/token" \
  --config "$root/services/sam/diagnostic.yaml" >"$work/sam.log" 2>&1 &
start_kr_bridge() {  # start_kr_bridge PORT: bridge-kr connecting to router a's public PORT
  cat >"$work/kr-bridge.yaml" <<EOF
name: bridge-kr
dds:
  domain: 7
  transport: tcp
  tcp: {connect: ["$WAN_A_PUBLIC:$1"]}
EOF
  rm -f "$work/kr.ready"
  ip netns exec "$WAN_NS_B" "$bin/bridge/urs-bridge" --space kr --server "$b:7600" --token-file "$work/token" \
    --config "$work/kr-bridge.yaml" --ready-file "$work/kr.ready" >>"$work/bridge-kr.log" 2>&1 &
  kr_bridge=$!
  disown -a  # killed with the namespaces
  eventually 20 test -e "$work/kr.ready" || fail "bridge-kr did not come up"
}
start_kr_bridge 7400

listed() { urs ls jp/rt.Diagnostic0 2>/dev/null | grep -q '^jp/rt.Diagnostic0 '; }
bound() { in_a "$bin/cli/urs" rtc --naming "$a:2809" ls jp-bridge.host_cxt 2>/dev/null | grep -q kr_diag.rtc; }

step "1. router a does not forward 7400: kr never sees jp"
# Discovery and matching took 1-3 s on this path in every run with the port forwarded.
sleep 8
listed && fail "jp listed in kr with its port not forwarded: $(urs ls 2>&1)"

# calls: a call each way, a 921,600-byte reply each way.
calls() {
  local out
  out=$(urs call jp/rt.Diagnostic0 echo '{"text":"from kr"}') || fail "call from kr to jp's RTC failed: $out"
  [[ "$out" == '{"result":"from kr"}' ]] || fail "the echo from kr answered $out"
  out=$(urs call --deadline-ms 20000 jp/rt.Diagnostic0 blob '{"size":921600}') || fail "921,600 B from jp failed"
  [[ $(python3 -c 'import base64, json, sys; print(len(base64.b64decode(json.load(sys.stdin)["result"])))' \
    <<<"$out") == 921600 ]] || fail "the reply from jp is not 921,600 bytes: ${out:0:80}"
  out=$(rtc_call jp-bridge.host_cxt/kr_diag.rtc:diagnostic echo '{"text":"from jp"}') ||
    fail "call from jp to kr's agent failed: $out"
  [[ "$out" == '{"result":"from jp"}' ]] || fail "the echo from jp answered $out"
  # A 921,600-byte reply from the connecting site is slow over Fast DDS 2.9's TCP (docs/sites.md,
  # Limits); under this path's loss it once held kr's liveliness past the lease, and the call
  # ended PROVIDER_GONE. Said, and tried once more: a second failure fails the test.
  out=$(rtc_call --deadline-ms 20000 jp-bridge.host_cxt/kr_diag.rtc:diagnostic blob '{"size":921600}') || {
    say "921,600 B from kr failed once (${out:0:160}); again"
    out=$(rtc_call --deadline-ms 20000 jp-bridge.host_cxt/kr_diag.rtc:diagnostic blob '{"size":921600}')
  } || fail "921,600 B from kr failed"
  [[ $(python3 -c 'import base64, json, sys; print(len(base64.b64decode(json.load(sys.stdin)["result"])))' \
    <<<"$out") == 921600 ]] || fail "the reply from kr is not 921,600 bytes: ${out:0:80}"
}
state() { urs context get jp/component/jp1.host_cxt/Diagnostic0.rtc 2>/dev/null | grep -q '"state":"Inactive"'; }

step "2. router a forwards 7400: the link comes up without a restart; calls both ways, 921,600 B, state"
wan_forward 7400 || fail "forward 7400"
t=$SECONDS
eventually 60 listed || fail "jp's RTC is not a service in kr: $(urs ls 2>&1)"
say "jp/rt.Diagnostic0 listed in kr $((SECONDS - t)) s after the port was forwarded"
eventually 30 bound || fail "kr's diag is not an RTC in jp"
eventually 20 state || fail "jp's RTC state is not in kr's context: $(urs context ls 'jp/*' 2>&1)"
calls
grep -q "the link over TCP: listening on port 7400, announced at $WAN_A_PUBLIC:7400" "$work/bridge-jp.log" ||
  fail "bridge-jp does not say where it listens"
say "path so far: $(wan_counters)"

step "3. the path cut for 20 s, then restored: everything passes again, no restart"
wan_cut
sleep 20
wan_restore
t=$SECONDS
passes() { listed && bound && urs call jp/rt.Diagnostic0 echo '{"text":"back"}' >/dev/null 2>&1; }
eventually 90 passes || fail "the link did not come back after the cut: $(urs ls 2>&1)"
say "calls pass again $((SECONDS - t)) s after the path returned"
calls
kill -0 "$jp_bridge" && kill -0 "$kr_bridge" || fail "a bridge is no longer the one started"
say "path: $(wan_counters)"

step "4. router a forwards public port 443 to 7400 instead: jp announces 443, kr connects to it"
kill "$kr_bridge" "$jp_bridge"
gone() { ! listed; }
eventually 30 gone || fail "jp's services stayed in kr without the bridges"
wan_unforward 7400 && wan_forward 443 7400 || fail "forward 443 to 7400"
start_jp_bridge "$WAN_A_PUBLIC:443"
start_kr_bridge 443
t=$SECONDS
eventually 60 listed || fail "jp's RTC is not a service in kr through port 443: $(urs ls 2>&1)"
say "jp/rt.Diagnostic0 listed in kr $((SECONDS - t)) s after bridge-kr started"
eventually 30 bound || fail "kr's diag is not an RTC in jp through port 443"
out=$(urs call jp/rt.Diagnostic0 echo '{"text":"via 443"}') || fail "call from kr through 443 failed: $out"
[[ "$out" == '{"result":"via 443"}' ]] || fail "the echo through 443 answered $out"
out=$(rtc_call jp-bridge.host_cxt/kr_diag.rtc:diagnostic echo '{"text":"back via 443"}') ||
  fail "call from jp through 443 failed: $out"
[[ "$out" == '{"result":"back via 443"}' ]] || fail "the echo back through 443 answered $out"

failed_step=""
say "$test_name: every step passed in $((SECONDS - t_start)) s"
