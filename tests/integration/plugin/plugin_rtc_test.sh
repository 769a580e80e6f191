#!/usr/bin/env bash
# plugin_rtc: urs-rtc-manager hosts the example's Calculator plug-in as an RT-Component
# ("Calculator") next to a built-in one, on a real omniNames; `urs rtc call` reaches its service
# port with the example's IDL loaded at run time. A plug-in refused (no symbols) is logged with its
# path and reason, and the manager still hosts its other components (a component of a type it might
# have given is logged and skipped).
#   plugin_rtc_test.sh OMNINAMES RTC_MANAGER URS PLUGIN_DIR IDL WORK_DIR
set -uo pipefail
omninames=$1
manager_bin=$2
urs_bin=$3
plugins=$4
idl=$5
work=$6
test_name=plugin_rtc
source "$(dirname "$0")/../../support/process_test.sh"

rm -rf "$work"
mkdir -p "$work"
start_omninames "$omninames" "$work"

cat >"$work/manager.yaml" <<YAML
plugins: [$plugins/libtest_plugin_no_symbol.so, test_calculator_plugin]
components:
  - type: Diagnostic
  - type: Calculator
    config: {params: {label: rt-calculator}}
  - type: Ghost
YAML
URS_PLUGIN_PATH=$plugins "$manager_bin" --space plugins --naming "$URS_NAMING" --host testhost --config "$work/manager.yaml" \
  --ready-file "$work/ready" >"$work/manager.log" 2>&1 &
manager=$!
pids+=($manager)
ready() { kill -0 "$manager" 2>/dev/null || fail "urs-rtc-manager exited"; test -s "$work/ready"; }
wait_for "urs-rtc-manager was not ready" ready
grep -qx 'testhost.host_cxt/Calculator0.rtc' "$work/ready" || fail "Calculator0 not bound: $(cat "$work/ready")"
grep -qx 'testhost.host_cxt/Diagnostic0.rtc' "$work/ready" || fail "Diagnostic0 not bound: $(cat "$work/ready")"
grep -qF "plug-in $plugins/libtest_plugin_no_symbol.so refused: no symbol urs_plugin_abi" "$work/manager.log" ||
  fail "the refusal of libtest_plugin_no_symbol.so is not logged with its path and reason"
grep -qF "component type 'Ghost' unknown" "$work/manager.log" || fail "the unknown component type Ghost is not logged"
[[ $(wc -l <"$work/ready") -eq 2 ]] || fail "expected 2 components bound: $(cat "$work/ready")"

port_path=testhost.host_cxt/Calculator0.rtc:calculator
reply=$("$urs_bin" rtc call "$port_path" divide '{"dividend":9,"divisor":4}' --idl "$idl" 2>"$work/call.log") ||
  fail "urs rtc call divide failed: $(cat "$work/call.log")"
[[ "$reply" == '{"result":2.25}' ]] || fail "divide answered '$reply'"
label=$("$urs_bin" rtc call "$port_path" label --idl "$idl" 2>>"$work/call.log") || fail "label failed"
[[ "$label" == '{"result":"rt-calculator"}' ]] || fail "label answered '$label'"
refusal=$("$urs_bin" rtc call "$port_path" divide '{"dividend":1,"divisor":0}' --idl "$idl" 2>&1)
rc=$?
[[ $rc -eq 1 && "$refusal" == *"USER_EXCEPTION PluginExample.DivisionByZero"* ]] ||
  fail "divide by zero over CORBA: exit $rc, '$refusal'"
echo=$("$urs_bin" rtc call testhost.host_cxt/Diagnostic0.rtc:diagnostic echo '{"text":"rt"}' 2>>"$work/call.log") ||
  fail "Diagnostic0 echo failed"
[[ "$echo" == '{"result":"rt"}' ]] || fail "echo answered '$echo'"
echo "plugin_rtc: Calculator plug-in hosted as an RTC and called over CORBA; the bad plug-in refused"
