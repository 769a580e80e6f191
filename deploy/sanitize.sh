#!/usr/bin/env bash
# Builds URSLink with one sanitizer into its own build folder and runs the threaded tests under it:
# the Planet transport, the CAMUS server, the agent host (SAM) and the bridge, with the real
# processes they start (CONTRIBUTING.md, "Sanitizers").
#   deploy/sanitize.sh [thread|address|undefined]     (default: thread)
# Environment:
#   URS_SANITIZE_BUILD_DIR  build folder (default build-<sanitizer>)
#   URS_SANITIZE_TESTS      test programs to run (default: the list below)
#   URS_JOBS                parallel compile jobs (default: nproc)
# Every instrumented process (a test and each program it starts) writes its reports to
# <build>/sanitizer-logs/<tsan|asan|ubsan>.<program>.<pid>, so reports from child processes are
# kept too. The script prints how often each kind of report occurred (its SUMMARY line) and in
# which programs, and exits 1 when any report was written or a test failed, 0 otherwise.
# omniORB and Fast DDS are not instrumented: tests/sanitizers/ holds the suppressions for them.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
sanitizer=${1:-thread}
case $sanitizer in
  thread|address|undefined) ;;
  *) echo "sanitize: unknown sanitizer '$sanitizer' (thread, address or undefined)" >&2; exit 2 ;;
esac
build=${URS_SANITIZE_BUILD_DIR:-$root/build-$sanitizer}
jobs=${URS_JOBS:-$(nproc)}
default_tests="planet_integration_test camus_integration_test agent_unit_test system_space_test
  corba_agent_hosting_test bridge_camus_side_test bridge_rt_side_test bridge_federation_test
  bridge_planet_proxy_test"
read -r -a tests <<<"$(echo ${URS_SANITIZE_TESTS:-$default_tests})"
# The programs the tests start.
programs=(urs-camus-server urs-sam urs urs-bridge urs-rtc-manager corba_agent_diagnostic_peer)

t0=$SECONDS
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DURS_SANITIZE="$sanitizer" >/dev/null
cmake --build "$build" -j "$jobs" --target "${tests[@]}" "${programs[@]}"
echo "sanitize: built in $((SECONDS - t0)) s"

logs=$build/sanitizer-logs
rm -rf "$logs"
mkdir -p "$logs"
supp=$root/tests/sanitizers
common="log_exe_name=1 ${URS_SANITIZER_OPTIONS:-}"
export TSAN_OPTIONS="suppressions=$supp/tsan.supp log_path=$logs/tsan exitcode=0 second_deadlock_stack=1 history_size=4 $common"
export ASAN_OPTIONS="log_path=$logs/asan detect_leaks=1 $common"
export LSAN_OPTIONS="suppressions=$supp/lsan.supp"
export UBSAN_OPTIONS="log_path=$logs/ubsan print_stacktrace=1 $common"

failed=()
for test in "${tests[@]}"; do
  exe=$(find "$build/tests" -type f -name "$test" -perm -u+x | head -1)
  [[ -n "$exe" ]] || { echo "sanitize: $test was not built" >&2; exit 2; }
  t=$SECONDS
  if (cd "$(dirname "$exe")" && timeout 1800 "$exe" --gtest_brief=1 >"$logs/$test.out" 2>&1); then
    echo "sanitize: $test passed ($((SECONDS - t)) s)"
  else
    echo "sanitize: $test FAILED ($((SECONDS - t)) s): see $logs/$test.out"
    failed+=("$test")
  fi
done

found=()
for report in "$logs"/tsan.* "$logs"/asan.* "$logs"/ubsan.*; do [[ -s "$report" ]] && found+=("$report"); done
echo "sanitize: $sanitizer, ${#tests[@]} test programs, ${#failed[@]} failed, ${#found[@]} process(es) reported"
if ((${#found[@]})); then
  echo "sanitize: reports by kind and place (count, SUMMARY line), full stacks in $logs:"
  cat "${found[@]}" | sed -n 's/^SUMMARY: //p' | sed -E 's/ \(pid=[0-9]+\)//; s/\+0x[0-9a-f]+//g' |
    sort | uniq -c | sort -rn || true
  echo "sanitize: programs that reported:"
  printf '%s\n' "${found[@]##*/}" | sed -E 's/^[a-z]+\.//; s/\.[0-9]+$//' | sort | uniq -c || true
fi
((${#found[@]} == 0 && ${#failed[@]} == 0))
