# Two sites across an emulated internet, for the tests and the bench (sourced; needs root).
# Test support, not product.
#
#   site a (WAN_A_LAN)        router a                  "internet"                 router b           site b (WAN_B_LAN)
#   192.168.10.2 ── lan ── 192.168.10.1 | 198.51.100.2 ── 198.51.100.1 | 203.0.113.1 ── 203.0.113.2 | 192.168.20.1 ── 192.168.20.2
#
# Each site is a network namespace behind a router namespace that does real NAT (iptables
# MASQUERADE on its internet side) and a stateful firewall: nothing comes in but replies to what
# went out, except on router a the TCP ports forwarded with wan_forward (DNAT to site a: the
# listening site). Router b lets only TCP out (no UDP at all: a site whose firewall lets one
# outbound TCP connection through). The sites' private addresses are routed nowhere on the
# internet: a site reaches the other only at its router's public address. With WAN_SAME_LAN=1 both
# sites use 192.168.10.0/24 (the same private address on both sides, as two real labs may).
#
# The internet namespace routes between the two public networks and is the bad path: in its
# FORWARD chain, a loss rule (iptables' statistic match, WAN_LOSS per packet, each direction) and a
# delay stage (NFQUEUE to wan-delay, WAN_DELAY_MS each direction: the kernel has no netem).
# wan_cut drops everything crossing it until wan_restore.
#
#   source wan.sh
#   wan_up TAG WAN_DELAY_BIN      the namespaces, the NAT, the path (WAN_DELAY_MS=40, WAN_LOSS=0.01)
#   wan_forward PORT [TO]         router a forwards TCP PORT (its public address) to site a's port TO
#   wan_unforward PORT [TO]       (default PORT)
#   in_a CMD..., in_b CMD...      run in a site (also in_ra, in_rb, in_net)
#   wan_cut, wan_restore          drop / pass everything on the path
#   wan_counters                  "lost=N delayed=N cut=N" packets so far on the path
#   wan_down                      kill everything in the namespaces and delete them (idempotent)
#   wan_test_begin                for a test script sourcing tests/e2e/steps.sh: $work, a temporary
#                                 folder for its logs; on exit, a failed step's logs, then wan_down
#
# Interface and namespace names carry TAG (keep it to 6 characters or fewer). wan_down kills what
# runs in the namespaces with SIGKILL: disown the jobs started there, or bash reports each killed.

WAN_DELAY_MS=${WAN_DELAY_MS:-40}
WAN_LOSS=${WAN_LOSS:-0.01}
WAN_A_LAN=192.168.10.2
WAN_B_LAN=192.168.20.2
WAN_A_PUBLIC=198.51.100.2
WAN_B_PUBLIC=203.0.113.2
WAN_QUEUE=0

in_a() { ip netns exec "$WAN_NS_A" "$@"; }
in_b() { ip netns exec "$WAN_NS_B" "$@"; }
in_ra() { ip netns exec "$WAN_NS_RA" "$@"; }
in_rb() { ip netns exec "$WAN_NS_RB" "$@"; }
in_net() { ip netns exec "$WAN_NS_NET" "$@"; }

# _wan_link NS1 IF1 NS2 IF2: a veth pair between two namespaces, both ends up. No segmentation
# offload (one GSO packet of 64 kB would otherwise cross the path, and be lost, as one): every
# packet on the path is one MTU-sized segment, as on a real internet path.
_wan_link() {
  ip link add "$2" gso_max_segs 1 type veth peer name "$4" gso_max_segs 1 || return 1
  ip link set "$2" netns "$1" && ip link set "$4" netns "$3" || return 1
  ip -n "$1" link set "$2" up && ip -n "$3" link set "$4" up
}

wan_up() {
  local tag=$1 delay_bin=$2
  WAN_TAG=$tag
  WAN_NS_A=urs-$tag-a WAN_NS_RA=urs-$tag-ra WAN_NS_NET=urs-$tag-net WAN_NS_RB=urs-$tag-rb WAN_NS_B=urs-$tag-b
  if [[ "${WAN_SAME_LAN:-0}" == 1 ]]; then WAN_B_LAN=192.168.10.2; fi
  local b_net=${WAN_B_LAN%.*}
  local ns
  for ns in "$WAN_NS_A" "$WAN_NS_RA" "$WAN_NS_NET" "$WAN_NS_RB" "$WAN_NS_B"; do
    ip netns add "$ns" || return 1
    ip -n "$ns" link set lo up
  done
  _wan_link "$WAN_NS_A" "w$tag-a" "$WAN_NS_RA" "w$tag-al" || return 1
  _wan_link "$WAN_NS_RA" "w$tag-aw" "$WAN_NS_NET" "w$tag-na" || return 1
  _wan_link "$WAN_NS_NET" "w$tag-nb" "$WAN_NS_RB" "w$tag-bw" || return 1
  _wan_link "$WAN_NS_RB" "w$tag-bl" "$WAN_NS_B" "w$tag-b" || return 1
  ip -n "$WAN_NS_A" addr add "$WAN_A_LAN/24" dev "w$tag-a"
  ip -n "$WAN_NS_RA" addr add 192.168.10.1/24 dev "w$tag-al"
  ip -n "$WAN_NS_RA" addr add "$WAN_A_PUBLIC/24" dev "w$tag-aw"
  ip -n "$WAN_NS_NET" addr add 198.51.100.1/24 dev "w$tag-na"
  ip -n "$WAN_NS_NET" addr add 203.0.113.1/24 dev "w$tag-nb"
  ip -n "$WAN_NS_RB" addr add "$WAN_B_PUBLIC/24" dev "w$tag-bw"
  ip -n "$WAN_NS_RB" addr add "$b_net.1/24" dev "w$tag-bl"
  ip -n "$WAN_NS_B" addr add "$WAN_B_LAN/24" dev "w$tag-b"
  ip -n "$WAN_NS_A" route add default via 192.168.10.1 || return 1
  ip -n "$WAN_NS_B" route add default via "$b_net.1" || return 1
  ip -n "$WAN_NS_RA" route add default via 198.51.100.1 || return 1
  ip -n "$WAN_NS_RB" route add default via 203.0.113.1 || return 1
  for ns in "$WAN_NS_RA" "$WAN_NS_NET" "$WAN_NS_RB"; do
    ip netns exec "$ns" sysctl -qw net.ipv4.ip_forward=1 || return 1
  done
  # Router a: NAT out, nothing in but replies and the forwarded ports.
  in_ra iptables -t nat -A POSTROUTING -o "w$tag-aw" -j MASQUERADE || return 1
  in_ra iptables -P FORWARD DROP
  in_ra iptables -A FORWARD -m conntrack --ctstate ESTABLISHED,RELATED -j ACCEPT
  in_ra iptables -A FORWARD -i "w$tag-al" -o "w$tag-aw" -j ACCEPT
  in_ra iptables -A FORWARD -i "w$tag-aw" -m conntrack --ctstate DNAT -j ACCEPT
  # Router b: NAT out, only TCP out, nothing in but replies.
  in_rb iptables -t nat -A POSTROUTING -o "w$tag-bw" -j MASQUERADE || return 1
  in_rb iptables -P FORWARD DROP
  in_rb iptables -A FORWARD -m conntrack --ctstate ESTABLISHED,RELATED -j ACCEPT
  in_rb iptables -A FORWARD -i "w$tag-bl" -o "w$tag-bw" -p tcp -j ACCEPT
  # The path: loss, then the delay stage. Its queue drops when nobody serves it (no --queue-bypass):
  # a dead delay stage is a dead path, never a fast one.
  if [[ "$WAN_LOSS" != 0 ]]; then
    in_net iptables -A FORWARD -m statistic --mode random --probability "$WAN_LOSS" \
      -m comment --comment wan-loss -j DROP || return 1
  fi
  if ((WAN_DELAY_MS > 0)); then
    in_net iptables -A FORWARD -m comment --comment wan-delay -j NFQUEUE --queue-num "$WAN_QUEUE" || return 1
    local ready
    ready=$(mktemp -u)
    # ip netns exec itself (not in_net, a function, which would run in a subshell): $! is the stage.
    ip netns exec "$WAN_NS_NET" "$delay_bin" --queue "$WAN_QUEUE" --delay-ms "$WAN_DELAY_MS" --ready-file "$ready" \
      >"${WAN_LOG_DIR:-/tmp}/wan-delay-$tag.log" 2>&1 &
    WAN_DELAY_PID=$!
    local i
    for i in $(seq 50); do [[ -e "$ready" ]] && break; sleep 0.1; done
    rm -f "$ready"
    kill -0 "$WAN_DELAY_PID" 2>/dev/null || { cat "${WAN_LOG_DIR:-/tmp}/wan-delay-$tag.log" >&2; return 1; }
  fi
}

wan_forward() {
  in_ra iptables -t nat -A PREROUTING -i "w$WAN_TAG-aw" -p tcp --dport "$1" -j DNAT --to-destination "$WAN_A_LAN:${2:-$1}"
}
wan_unforward() {
  in_ra iptables -t nat -D PREROUTING -i "w$WAN_TAG-aw" -p tcp --dport "$1" -j DNAT --to-destination "$WAN_A_LAN:${2:-$1}"
}

wan_cut() { in_net iptables -I FORWARD 1 -m comment --comment wan-cut -j DROP; }
wan_restore() { in_net iptables -D FORWARD -m comment --comment wan-cut -j DROP; }

wan_counters() {
  in_net iptables -L FORWARD -v -n -x | awk '
    /wan-loss/ {lost=$1} /wan-delay/ {delayed=$1} /wan-cut/ {cut=$1}
    END {printf "lost=%d delayed=%d cut=%d\n", lost, delayed, cut}'
}

wan_down() {
  local ns
  [[ -n "${WAN_DELAY_PID:-}" ]] && kill "$WAN_DELAY_PID" 2>/dev/null && wait "$WAN_DELAY_PID" 2>/dev/null
  for ns in "${WAN_NS_A:-}" "${WAN_NS_B:-}" "${WAN_NS_RA:-}" "${WAN_NS_RB:-}" "${WAN_NS_NET:-}"; do
    [[ -n "$ns" ]] || continue
    ip netns pids "$ns" 2>/dev/null | xargs -r kill -9 2>/dev/null
    ip netns del "$ns" 2>/dev/null
  done
  WAN_DELAY_PID=""
}

wan_test_begin() {
  work=$(mktemp -d)
  WAN_LOG_DIR=$work
  trap _wan_test_end EXIT
  trap 'exit 130' INT TERM
}
_wan_test_end() {
  local rc=$? f
  if [[ $rc -ne 0 || -n "$failed_step" ]]; then
    echo "==== step failed: ${failed_step:-setup}; logs:"
    for f in "$work"/*.log; do [[ -e "$f" ]] && { echo "---- $f"; tail -n 20 "$f"; }; done
  fi
  wan_down
  rm -rf "$work"
}
