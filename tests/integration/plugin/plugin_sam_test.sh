#!/usr/bin/env bash
# plugin_sam: a real urs-camus-server and urs-sam loading agent plug-ins from its config. The
# example's Calculator plug-in (found by name in plugin_path) is called with urs; a missing file, a
# library without the symbols, another ABI version and a plug-in that registers nothing are each
# refused with their path and reason while the SAM keeps serving its other agents (diagnostic and
# the calculator); an agent of a type no plug-in gave is then dropped, not fatal. Without a refused
# plug-in such an agent, a plugin_path that is not a folder, and params the plug-in's factory
# refuses are config errors (exit 2).
# With urs-bridge and omniNames, an RT consumer (urs rtc call) calls the agent through the bridge.
#   plugin_sam_test.sh SERVER SAM URS PLUGIN_DIR WORK_DIR IDL [BRIDGE]
set -uo pipefail
server_bin=$1
sam_bin=$2
urs_bin=$3
plugins=$4
work=$5
idl=$6
bridge_bin=${7:-}
test_name=plugin_sam
source "$(dirname "$0")/../../support/process_test.sh"

rm -rf "$work"
mkdir -p "$work"
"$server_bin" --space plugins --listen 127.0.0.1:0 --port-file "$work/port" >"$work/server.log" 2>&1 &
pids+=($!)
wait_for "the server wrote no port file" test -s "$work/port"
export URS_SERVER=127.0.0.1:$(cat "$work/port")

cat >"$work/sam.yaml" <<YAML
plugins:
  - test_calculator_plugin
  - $work/libmissing.so
  - $plugins/libtest_plugin_no_symbol.so
  - $plugins/libtest_plugin_wrong_abi.so
  - $plugins/libtest_plugin_registers_nothing.so
plugin_path: [$plugins]
agents:
  - {name: diag, type: diagnostic}
  - {name: calc, type: calculator, params: {label: lab-calculator}}
  - {name: ghost, type: ghost}
YAML
"$sam_bin" --space plugins --server "$URS_SERVER" --config "$work/sam.yaml" >"$work/sam.log" 2>&1 &
sam=$!
pids+=($sam)
registered() {
  kill -0 "$sam" 2>/dev/null || fail "urs-sam exited"
  "$urs_bin" ls 2>/dev/null | grep -q '^calc .*PluginExample.Calculator' &&
    "$urs_bin" ls 2>/dev/null | grep -q '^diag '
}
wait_for "calc and diag were not registered" registered

# Each refusal: path and reason in the log.
expect_log() { grep -qF -- "$1" "$work/sam.log" || fail "the SAM's log lacks: $1"; }
expect_log "plug-in $plugins/libtest_calculator_plugin.so loaded: agent type(s) calculator"
expect_log "plug-in $work/libmissing.so refused: no such file"
expect_log "plug-in $plugins/libtest_plugin_no_symbol.so refused: no symbol urs_plugin_abi"
expect_log "plug-in $plugins/libtest_plugin_wrong_abi.so refused: built for plug-in ABI version 1002, this program loads version 2"
expect_log "plug-in $plugins/libtest_plugin_registers_nothing.so refused: registers no agent type"
expect_log "agents[2].type: unknown agent type 'ghost'"
"$urs_bin" ls 2>/dev/null | grep -q '^ghost ' && fail "ghost was registered"

# The plug-in's agent, and the built-in one beside it.
reply=$("$urs_bin" call calc divide '{"dividend":7,"divisor":2}' 2>"$work/call.log") || fail "divide failed"
[[ "$reply" == '{"result":3.5}' ]] || fail "divide answered '$reply'"
refusal=$("$urs_bin" call calc divide '{"dividend":1,"divisor":0}' 2>&1)
rc=$?
[[ $rc -eq 1 && "$refusal" == *USER_EXCEPTION* && "$refusal" == *DivisionByZero* ]] ||
  fail "divide by zero: exit $rc, '$refusal' (expected the DivisionByZero exception)"
label=$("$urs_bin" call calc label 2>>"$work/call.log") || fail "label failed"
[[ "$label" == '{"result":"lab-calculator"}' ]] || fail "label answered '$label' (params not handed to the factory?)"
echo=$("$urs_bin" call diag echo '{"text":"still here"}' 2>>"$work/call.log") || fail "diag echo failed"
[[ "$echo" == '{"result":"still here"}' ]] || fail "echo answered '$echo'"

# An RT consumer reaches the plug-in's agent through urs-bridge (the CAMUS service as an RTC), the
# consumer loading the example's IDL at run time.
if [[ -n "$bridge_bin" ]] && omninames=$(command -v omniNames); then
  start_omninames "$omninames" "$work"
  printf 'name: bridge-plugin\ncamus_to_rt:\n  poll_ms: 200\n  services:\n    - {match: calc, instance: "camus_{service}"}\n' \
    >"$work/bridge.yaml"
  "$bridge_bin" --space plugins --server "$URS_SERVER" --naming "$URS_NAMING" --host bridgehost \
    --config "$work/bridge.yaml" >"$work/bridge.log" 2>&1 &
  pids+=($!)
  rt_call() { "$urs_bin" rtc call bridgehost.host_cxt/camus_calc.rtc:calculator "$@" --idl "$idl" 2>&1; }
  offered() { rt_call calls >/dev/null; }
  wait_for "the bridge did not offer calc to RT consumers" offered
  reply=$(rt_call divide '{"dividend":5,"divisor":4}') || fail "urs rtc call through the bridge failed: $reply"
  [[ "$reply" == '{"result":1.25}' ]] || fail "divide through the bridge answered '$reply'"
  refusal=$(rt_call divide '{"dividend":2,"divisor":0}')
  rc=$?
  [[ $rc -eq 1 && "$refusal" == *"USER_EXCEPTION PluginExample.DivisionByZero"* ]] ||
    fail "divide by zero through the bridge: exit $rc, '$refusal'"
fi

# Without a refused plug-in, an unknown type is a config error, as is a plugin_path that is no folder.
printf 'plugins: [%s/libtest_calculator_plugin.so]\nagents: [{name: g, type: ghost}]\n' "$plugins" >"$work/unknown.yaml"
out=$("$sam_bin" --space plugins --server "$URS_SERVER" --config "$work/unknown.yaml" 2>&1)
rc=$?
[[ $rc -eq 2 && "$out" == *"agents[0].type: unknown agent type 'ghost' (known: "*calculator* ]] ||
  fail "unknown type with every plug-in loaded: exit $rc, '$out'"
printf 'plugins: [x]\nplugin_path: [%s/nofolder]\nagents: [{name: d, type: diagnostic}]\n' "$work" >"$work/path.yaml"
out=$("$sam_bin" --space plugins --server "$URS_SERVER" --config "$work/path.yaml" 2>&1)
rc=$?
[[ $rc -eq 2 && "$out" == *"plugin_path[0]: '$work/nofolder' is not a folder"* ]] ||
  fail "plugin_path not a folder: exit $rc, '$out'"
# A plug-in's factory refusing its params stops the SAM, naming the agent.
printf 'plugins: [%s/libtest_calculator_plugin.so]\nagents: [{name: c, type: calculator, params: {label: [1, 2]}}]\n' \
  "$plugins" >"$work/params.yaml"
out=$("$sam_bin" --space plugins --server "$URS_SERVER" --config "$work/params.yaml" 2>&1)
rc=$?
[[ $rc -eq 2 && "$out" == *"agent 'c' (type calculator): "* ]] || fail "bad params: exit $rc, '$out'"
echo "plugin_sam: calculator plug-in served, 4 bad plug-ins refused with path and reason, diag kept serving"
