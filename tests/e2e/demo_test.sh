#!/usr/bin/env bash
# e2e: runs the local demo (deploy/demo-local.sh) on the built binaries and checks what a user
# would see at each step. Fails on the first missing line, printing the demo's output.
set -uo pipefail
root=$1
build=$2
out=$(URS_DEMO_NO_BUILD=1 URS_BUILD_DIR="$build" "$root/deploy/demo-local.sh" 2>&1)
rc=$?
fail() { echo "demo_test: $1"; echo "---- demo output"; echo "$out"; exit 1; }
[[ $rc -eq 0 ]] || fail "demo exited with $rc"
expect() { grep -qE -- "$1" <<<"$out" || fail "missing: $1"; }
expect '^diag +URS\.Diagnostic +[^ ]+ +sam@'
expect '^  string echo\(in string text\);$'
expect '^\{"result":"hello from the demo"\}$'
expect 'USER_EXCEPTION URS\.Failure \{"reason":"battery low","code":7\}'
expect 'DEADLINE_EXCEEDED'
expect '"topic":"demo/door".*"text":"opened"'
expect '"lux":420'
expect '"state":"succeeded"'
expect 'diag listed again [0-9]+ ms after the restart'
expect '^\{"result":"still here"\}$'
expect '^  Diagnostic0\.rtc +Inactive'
expect 'DiagnosticCaller0: [1-9][0-9]* echo replies, 0 failures'
expect 'urs: rtc deact: demo-host\.host_cxt/DiagnosticCaller0\.rtc: PRECONDITION_NOT_MET'
expect 'Sink0: received [1-9][0-9]* counts'
expect '^rt\.Diagnostic0 +URS\.Diagnostic +[^ ]+ +bridge-demo +available +rtc:demo-host\.host_cxt/Diagnostic0\.rtc:diagnostic'
expect '^diag +URS\.Diagnostic +[^ ]+ +sam@.* native$'
expect '^\{"result":"hello RT, from CAMUS"\}$'
expect 'rt\.Diagnostic0\.fail: USER_EXCEPTION URS\.Failure \{"reason":"wheel stuck","code":3\}'
expect 'camus_diag\.rtc'
expect '"key":"counter\.count","value":\{.*"data":[0-9]+'
expect '^0$'
echo "demo_test: every step of the demo produced what it should"
