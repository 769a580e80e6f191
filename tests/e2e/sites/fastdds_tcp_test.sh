#!/usr/bin/env bash
# e2e (Fast DDS over TCP between sites): what Fast DDS 2.9 does over its TCPv4 transport through
# two NATs and a bad path (wan.sh), with the link's own types and QoS (dds-tcp-probe: keyed,
# reliable, transient-local catalog and DDS-RPC topics), no bridge. Site a listens on TCP 7400,
# forwarded by its router; site b only connects out, to a's public address. Each check is a
# setting the link's TCP configuration depends on (docs/sites.md):
#   1. b connects out, a announces its public address: discovery, the catalog (transient-local)
#      and calls with 921,600-byte replies all pass through b's one connection;
#   2. a announcing no public address: b discovers a but matches none of its endpoints (a's
#      locators name its private address, which b cannot reach);
#   3. a port the router does not forward: nothing at all;
#   4. DDS-Security (deploy/pki.sh's PKI) on top of the same connection;
#   5. a Fast DDS discovery server over TCP (a the server, b a client that does not listen);
#   6. a router forwarding another public port (443 to a's 7400): a announcing its public
#      address (set_WAN_address) with its listening port is never matched; a announcing its own
#      locators at the public address and port is;
#   7. a tunnel (a relay standing for one through a proxy) in front of b: ending on another host
#      (router b) it works; ending on b's own host, b never discovers a;
#   8. both sites on the same private network (192.168.10.2 each): b announcing no WAN address
#      is taken by a for one of its own and never answered; b announcing any WAN address, even
#      its own private one (which a has too), is answered.
# Needs root (ip netns, iptables, NFQUEUE); always removes its namespaces.
#   tests/e2e/sites/fastdds_tcp_test.sh [SOURCE_DIR [BUILD_DIR]]
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=${1:-$(cd "$here/../../.." && pwd)}
build=${2:-${URS_BUILD_DIR:-$root/build}}
tools=$build/tests/e2e/sites
test_name=e2e_sites_fastdds_tcp
source "$here/../steps.sh"
source "$here/wan.sh"

[[ $(id -u) -eq 0 ]] || die "needs root for ip netns (run as root, as CI does)"
for tool in wan-delay dds-tcp-probe; do [[ -x "$tools/$tool" ]] || die "$tools/$tool is not built"; done

wan_test_begin

# A negative check waits this long for what must not happen: discovery and matching took 1-2 s
# on this path in every run.
quiet_s=6
probe=$tools/dds-tcp-probe
# link NAME "A FLAGS" "B FLAGS" LIMIT_S: site a serves (pong), site b calls (ping) until 5 replies
# or LIMIT_S; b's exit status (0: it got them) and both logs in $work/NAME.{a,b}.log.
link() {
  local name=$1 a_flags=$2 b_flags=$3 limit=$4
  # shellcheck disable=SC2086
  ip netns exec "$WAN_NS_A" "$probe" --role pong --space jp --peer-space kr --duration-s $((limit + 2)) $a_flags \
    >"$work/$name.a.log" 2>&1 &
  local a=$!
  # shellcheck disable=SC2086
  ip netns exec "$WAN_NS_B" "$probe" --role ping --space kr --peer-space jp --duration-s "$limit" --replies 5 \
    --interval-ms 20 --report-every 1 $b_flags >"$work/$name.b.log" 2>&1
  local rc=$?
  kill "$a" 2>/dev/null
  { wait "$a"; } 2>/dev/null
  return $rc
}
answered() { grep -q " reply " "$work/$1.b.log"; }

step "two sites behind NAT, 40 ms each way and 1 % loss; site a's TCP 7400 forwarded"
wan_up "f$$" "$tools/wan-delay" || fail "wan_up"
wan_forward 7400 || fail "forward"
public="--listen 7400 --wan $WAN_A_PUBLIC"

step "1. b connects out to a's public address: discovery, catalog, calls with 921,600-byte replies"
link plain "$public --reply-bytes 921600" "--peer $WAN_A_PUBLIC:7400" 30 || fail "no 5 replies: $(tail -n 3 "$work/plain.b.log")"
grep -q "catalog jp/probe.echo" "$work/plain.b.log" || fail "b never read a's catalog entry (transient-local)"
grep -q " reply [0-9]* [0-9]* 921600$" "$work/plain.b.log" || fail "no 921,600-byte reply"
say "$(grep summary "$work/plain.b.log")"

step "2. a announcing no public address: discovered, never matched"
link nowan "--listen 7400" "--peer $WAN_A_PUBLIC:7400" "$quiet_s" && fail "calls answered without a public address"
grep -q "participant discovered probe/jp" "$work/nowan.b.log" || fail "b did not even discover a: $(head -n 3 "$work/nowan.b.log")"
grep -q "matched request writer" "$work/nowan.b.log" && fail "b matched a's endpoints at a's private address"

step "3. a port router a does not forward: nothing"
link unforwarded "--listen 7401 --wan $WAN_A_PUBLIC" "--peer $WAN_A_PUBLIC:7401" "$quiet_s" &&
  fail "calls answered through a port not forwarded"
grep -q "participant discovered" "$work/unforwarded.b.log" && fail "b discovered a through a port not forwarded"

step "4. DDS-Security on the same connection"
pki=$work/pki
for args in "init $pki" "governance $pki" "member $pki jp --calls kr" "member $pki kr --calls jp"; do
  # shellcheck disable=SC2086
  "$root/deploy/pki.sh" $args >>"$work/pki.log" 2>&1 || fail "deploy/pki.sh $args: $(tail -n 3 "$work/pki.log")"
done
link secured "$public --pki $pki" "--peer $WAN_A_PUBLIC:7400 --pki $pki" 30 ||
  fail "no 5 replies on the secured link: $(tail -n 3 "$work/secured.b.log")"

step "5. a discovery server over TCP: a the server (logical port 7400), b a client that does not listen"
link server "$public --discovery server --logical-port 7400" \
  "--discovery client --server $WAN_A_PUBLIC:7400 --logical-port 7400" 30 ||
  fail "no 5 replies through the discovery server: $(tail -n 3 "$work/server.b.log")"

step "6. router a forwards its public port 443 to a's 7400: a announces the public port itself"
wan_unforward 7400 && wan_forward 443 7400 || fail "forward 443 instead of 7400"
link mapped_wan "$public" "--peer $WAN_A_PUBLIC:443" "$quiet_s" && fail "matched with a announcing port 7400 behind 443"
link mapped "--listen 7400 --announce $WAN_A_PUBLIC --announce-port 443" "--peer $WAN_A_PUBLIC:443" 30 ||
  fail "no 5 replies with a's locators at $WAN_A_PUBLIC:443: $(tail -n 3 "$work/mapped.b.log")"

step "7. a tunnel in front of b: ending on another host it works, on b's own host it does not"
relay() {  # relay NAMESPACE ADDRESS: a relay at ADDRESS:7600 to a's public 7400, until the step ends
  ip netns exec "$1" python3 "$here/tcp_relay.py" "$2" 7600 "$WAN_A_PUBLIC" 7400 >"$work/relay.log" 2>&1 &
  disown
  eventually 5 in_b python3 -c "import socket; socket.create_connection(('$2', 7600), timeout=1).close()" ||
    fail "the relay at $2 does not listen"
}
wan_unforward 443 7400 && wan_forward 7400 || fail "forward 7400 again"
relay "$WAN_NS_RB" 192.168.20.1
link tunnel "$public" "--peer 192.168.20.1:7600" 30 || fail "no 5 replies through a tunnel on router b: $(tail -n 3 "$work/tunnel.b.log")"
relay "$WAN_NS_B" 127.0.0.1
link tunnel_local "$public" "--peer 127.0.0.1:7600" "$quiet_s" && fail "answered through a tunnel on b's own host"
grep -q "participant discovered probe/jp" "$work/tunnel_local.b.log" && fail "b discovered a through a local tunnel"

step "8. both sites on the same private network: b must announce a WAN address, any"
wan_down
WAN_SAME_LAN=1 wan_up "s$$" "$tools/wan-delay" || fail "wan_up (same private network)"
wan_forward 7400 || fail "forward"
[[ "$WAN_A_LAN" == "$WAN_B_LAN" ]] || fail "the sites do not share their private address"
link samelan "$public" "--peer $WAN_A_PUBLIC:7400" "$quiet_s" && fail "answered although b's address is a's own"
link samelan_wan "$public" "--peer $WAN_A_PUBLIC:7400 --wan $WAN_B_LAN" 30 ||
  fail "no 5 replies with b's own address as its WAN address: $(tail -n 3 "$work/samelan_wan.b.log")"

failed_step=""
say "$test_name: every step passed in $((SECONDS - t_start)) s"
