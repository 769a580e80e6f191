#!/usr/bin/env bash
# e2e (sites harness): the emulated internet of wan.sh checked with plain tools, so that what the
# site tests find is the link's doing and not the harness's. Two sites behind NAT routers, the
# bad path between them (40 ms each way, 1 % loss), site a's TCP port 7500 forwarded:
#   - a TCP round trip from b to a's public address answers, and takes at least the path's
#     80 ms (the delay stage holds every packet);
#   - site a sees the connection coming from router b's public address (NAT), not b's own;
#   - a port not forwarded is refused, a's private address is unreachable, and a cannot reach b;
#   - site b sends no UDP out (its router passes only TCP), while site a's UDP does reach the
#     internet (the check of b's could not otherwise fail);
#   - the loss rule drops packets of a 921,600-byte transfer, which still arrives whole;
#   - cut, nothing passes; restored, the same round trip answers again.
# Needs root (ip netns, iptables, NFQUEUE); always removes its namespaces.
#   tests/e2e/sites/harness_test.sh [SOURCE_DIR [BUILD_DIR]]
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=${1:-$(cd "$here/../../.." && pwd)}
build=${2:-${URS_BUILD_DIR:-$root/build}}
tools=$build/tests/e2e/sites
test_name=e2e_sites_harness
source "$here/../steps.sh"
source "$here/wan.sh"

[[ $(id -u) -eq 0 ]] || die "needs root for ip netns (run as root, as CI does)"
command -v iptables >/dev/null || die "iptables (Debian: iptables) is not installed"
for tool in wan-delay tcp-rtt; do [[ -x "$tools/$tool" ]] || die "$tools/$tool is not built"; done

wan_test_begin

step "two sites behind NAT, the path between them 40 ms each way with 1 % loss"
wan_up "h$$" "$tools/wan-delay" || fail "wan_up"
wan_forward 7500 || fail "forward 7500"
ip netns exec "$WAN_NS_A" "$tools/tcp-rtt" --serve 0.0.0.0:7500 --ready-file "$work/a7500.ready" >"$work/a7500.log" 2>&1 &
ip netns exec "$WAN_NS_A" "$tools/tcp-rtt" --serve 0.0.0.0:7501 --ready-file "$work/a7501.ready" >"$work/a7501.log" 2>&1 &
ip netns exec "$WAN_NS_B" "$tools/tcp-rtt" --serve 0.0.0.0:7500 --ready-file "$work/b7500.ready" >"$work/b7500.log" 2>&1 &
disown -a  # killed with the namespaces
for ready in a7500 a7501 b7500; do eventually 5 test -e "$work/$ready.ready" || fail "tcp-rtt $ready did not listen"; done

step "a round trip from b to a's public address, through both NATs and the path"
out=$(in_b timeout 20 "$tools/tcp-rtt" --connect "$WAN_A_PUBLIC:7500" --count 20) || fail "no round trip: $out"
p50_us=$(sed -n 's/.*p50_us=\([0-9]*\).*/\1/p' <<<"$out")
((p50_us >= 2 * WAN_DELAY_MS * 1000)) || fail "a round trip took ${p50_us} us, less than the path's $((2 * WAN_DELAY_MS)) ms"
say "raw TCP round trip over the path: $out"

step "site a sees the connection from router b's public address"
peer=$(in_a python3 -c '
import socket, sys
s = socket.socket(); s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1); s.bind(("0.0.0.0", 7502)); s.listen(1)
s.settimeout(10); c, addr = s.accept(); print(addr[0])' &
  sleep 0.5
  wan_forward 7502
  in_b timeout 10 python3 -c "import socket; socket.create_connection(('$WAN_A_PUBLIC', 7502), timeout=5).close()"
  wait)
[[ "$peer" == "$WAN_B_PUBLIC" ]] || fail "site a saw the connection from '$peer', not from $WAN_B_PUBLIC"

step "refused: a port not forwarded, a's private address, and anything towards b"
in_b timeout 10 "$tools/tcp-rtt" --connect "$WAN_A_PUBLIC:7501" --count 1 >"$work/unforwarded.log" 2>&1 &&
  fail "a port router a does not forward answered"
in_b timeout 10 "$tools/tcp-rtt" --connect "$WAN_A_LAN:7500" --count 1 >"$work/private.log" 2>&1 &&
  fail "site a's private address answered from b"
in_a timeout 10 "$tools/tcp-rtt" --connect "$WAN_B_PUBLIC:7500" --count 1 >"$work/inbound.log" 2>&1 &&
  fail "site b answered a connection from outside"

step "site b sends no UDP out; site a's UDP reaches the internet"
udp_from() {  # udp_from SITE_COMMAND TARGET: "got" when a datagram reached the internet namespace
  in_net python3 -c '
import socket, sys
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind((sys.argv[1], 9999)); s.settimeout(3)
try:
    s.recv(100); print("got")
except socket.timeout:
    print("none")' "$2" &
  local listener=$!
  sleep 0.5
  $1 python3 -c "import socket; s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
for _ in range(5): s.sendto(b'x', ('$2', 9999))"
  wait "$listener"
}
[[ $(udp_from in_a 198.51.100.1) == got ]] || fail "site a's UDP did not reach the internet: the check cannot tell"
[[ $(udp_from in_b 203.0.113.1) == none ]] || fail "site b's router let UDP out"

step "a 921,600-byte transfer arrives whole while the path loses packets"
before=$(wan_counters)
out=$(in_b timeout 60 "$tools/tcp-rtt" --connect "$WAN_A_PUBLIC:7500" --reply-bytes 921600 --count 5) ||
  fail "the transfers did not complete: $out"
after=$(wan_counters)
lost_before=$(sed 's/lost=\([0-9]*\).*/\1/' <<<"$before")
lost_after=$(sed 's/lost=\([0-9]*\).*/\1/' <<<"$after")
((lost_after > lost_before)) || fail "the path lost nothing of 5 x 921,600 bytes ($before -> $after)"
say "921,600 B replies: $out; path: $before -> $after"

step "cut: nothing passes; restored: the round trip answers again"
wan_cut || fail "cut"
in_b timeout 4 "$tools/tcp-rtt" --connect "$WAN_A_PUBLIC:7500" --count 1 >"$work/cut.log" 2>&1 &&
  { wan_restore; fail "a round trip answered through the cut path"; }
cut=$(wan_counters)
[[ "$cut" =~ cut=([0-9]+) ]] && ((BASH_REMATCH[1] > 0)) || fail "the cut dropped nothing: $cut"
wan_restore || fail "restore"
out=$(in_b timeout 20 "$tools/tcp-rtt" --connect "$WAN_A_PUBLIC:7500" --count 3) || fail "no round trip after the cut: $out"

failed_step=""
say "$test_name: every step passed in $((SECONDS - t_start)) s"
