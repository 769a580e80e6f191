# Shared by the e2e scripts (sourced): timestamped steps, failures that name the step, and bounded
# retries. The sourcing script sets `test_name` first and clears `failed_step` when it passes.
t_start=$SECONDS
failed_step=""
say() { printf '[%4ds] %s\n' $((SECONDS - t_start)) "$*"; }
die() { echo "$test_name: FAILED: $*" >&2; exit 1; }
step() { failed_step=$1; say "$1"; }
fail() { echo "$test_name: FAILED at '$failed_step': $*" >&2; exit 1; }

# Retries a check (a command) for up to LIMIT seconds: eventually LIMIT COMMAND...
eventually() {
  local limit=$1; shift
  local deadline=$((SECONDS + limit))
  until "$@"; do
    ((SECONDS < deadline)) || return 1
    sleep 0.5
  done
}
