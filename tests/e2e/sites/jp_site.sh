# Site a's space, jp, as e2e_sites_link and the bench across sites (tests/bench/wan_bench.sh) run
# it: the real programs in wan.sh's site a (sourced after wan.sh and tests/e2e/steps.sh; uses
# $work for configurations, logs and ready files (one per run of the programs: omniNames
# refuses to start on the log of another), and $bin, the build's services folder). Each
# function returns 1 when what it starts does not come up; the caller says so.
#   jp_rt_up                    omniNames on 2809 and urs-rtc-manager with a Diagnostic RTC (jp1.host_cxt)
#   jp_bridge_up PUBLIC [DDS]   bridge-jp offering every RTC as rt.{instance}, listening on TCP 7400
#                               announced at PUBLIC (IP or IP:PORT); DDS: more of its `dds` keys,
#                               as flow-style YAML (e.g. "state: {period_ms: 200}"); $jp_bridge its pid
# SERVER_CPU=(taskset -c 1) runs them on that CPU (the bench's --pin). Test support, not product.

jp_rt_up() {
  local a=$WAN_A_LAN
  # ip netns exec itself (not in_a, a function, which would run in a subshell).
  ip netns exec "$WAN_NS_A" "${SERVER_CPU[@]}" omniNames -start 2809 -datadir "$work" -logdir "$work" \
    -ORBendPoint "giop:tcp:$a:2809" >"$work/naming.log" 2>&1 &
  eventually 10 in_a bash -c "exec 3<>/dev/tcp/$a/2809" 2>/dev/null || return 1
  printf 'components:\n  - type: Diagnostic\n' >"$work/rtc.yaml"
  ip netns exec "$WAN_NS_A" "${SERVER_CPU[@]}" "$bin/rtc-manager/urs-rtc-manager" --space jp --naming "$a:2809" \
    --host jp1 --config "$work/rtc.yaml" --listen "$a:2810" --ready-file "$work/rtc.ready" \
    >"$work/rtc-manager.log" 2>&1 &
  eventually 20 test -e "$work/rtc.ready"
}

jp_bridge_up() {
  local a=$WAN_A_LAN
  cat >"$work/jp-bridge.yaml" <<EOF
name: bridge-jp
rt_to_camus:
  poll_ms: 100
  providers: [{match: "*", name: "rt.{instance}"}]
dds:
  domain: 7
  transport: tcp
  tcp: {listen: 7400, public: "$1"}
  ${2:-}
EOF
  rm -f "$work/jp.ready"
  # ip netns exec itself: $! is the bridge.
  ip netns exec "$WAN_NS_A" "${SERVER_CPU[@]}" "$bin/bridge/urs-bridge" --space jp --naming "$a:2809" \
    --listen "$a:2811" --host jp-bridge --config "$work/jp-bridge.yaml" --ready-file "$work/jp.ready" \
    >>"$work/bridge-jp.log" 2>&1 &
  jp_bridge=$!
  eventually 20 test -e "$work/jp.ready"
}
