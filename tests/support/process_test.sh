# Sourced by the shell integration tests, after they set `test_name` and `work` (the folder of
# their logs): the processes they start (pids+=(...)) are killed on exit; fail() prints the reason
# and the tail of every log in $work and exits 1; wait_for polls a condition.
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null; done
}
trap cleanup EXIT
fail() {
  echo "$test_name: $*"
  for log in "$work"/*.log; do [[ -s "$log" ]] && { echo "---- $log"; tail -40 "$log"; }; done
  exit 1
}
# wait_for WHAT COMMAND...: polls COMMAND every 0.1 s for at most 30 s, else fails with WHAT.
wait_for() {
  local what=$1
  shift
  for _ in $(seq 300); do "$@" && return 0; sleep 0.1; done
  fail "$what within 30 s"
}

# start_omninames OMNINAMES WORK: omniNames on a free port of 127.0.0.1 (a few tries: another test
# may take the port first), its pid in `pids`; exports URS_NAMING=127.0.0.1:<port>.
start_omninames() {
  local omninames=$1 work=$2 port names
  for _ in 1 2 3 4 5; do
    port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
    mkdir -p "$work/names-$port"
    "$omninames" -start "$port" -datadir "$work/names-$port" -ORBendPoint "giop:tcp:127.0.0.1:$port" \
      >"$work/omninames.log" 2>&1 &
    names=$!
    for _ in $(seq 100); do
      grep -q 'Root context is' "$work/omninames.log" && break
      kill -0 "$names" 2>/dev/null || break
      sleep 0.1
    done
    if kill -0 "$names" 2>/dev/null && grep -q 'Root context is' "$work/omninames.log"; then
      pids+=("$names")
      export URS_NAMING=127.0.0.1:$port
      return 0
    fi
    kill "$names" 2>/dev/null
    wait "$names" 2>/dev/null
  done
  fail "omniNames did not start"
}
