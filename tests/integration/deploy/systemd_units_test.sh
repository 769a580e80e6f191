#!/usr/bin/env bash
# systemd_units: the units as the .deb installs them (`cmake --install` with prefix /usr into a root,
# DESTDIR), and what they promise.
# 1. `systemd-analyze verify` of every unit (a template as an instance), in that root with the host's
#    own units beside them (the targets they name): any word from it fails the test, since verify
#    exits 0 on unknown keys.
# 2. Readiness (Type=notify, NotifyAccess=main): each program started as its unit starts it — the
#    installed urs-entrypoint ROLE with the unit's Environment= lines (addresses and folders moved to
#    this test's), and NOTIFY_SOCKET naming a socket this test listens on — says READY=1 from its main
#    PID, and at that moment serves: the CAMUS server answers `urs ls`; the SAM's service is listed (a
#    SAM whose registration is refused never says it); the naming service answers urs-health
#    (the unit's ExecStartPost); the RT manager's components are bound, its ORB on a port of its own
#    (URS_ORB_PORT=0 of the template).
#   systemd_units_test.sh SOURCE_DIR BUILD_DIR
set -uo pipefail
root=$1
build=$2
work=$build/systemd-units-test
test_name=systemd_units
source "$(dirname "$0")/../../support/process_test.sh"
here=$(cd "$(dirname "$0")" && pwd)

command -v systemd-analyze >/dev/null || fail "systemd-analyze is missing (Debian: apt-get install systemd)"
rm -rf "$work"
mkdir -p "$work"
sysroot=$work/root
DESTDIR=$sysroot cmake --install "$build" --prefix /usr >"$work/install.log" 2>&1 || fail "cmake --install failed"
unitdir=$sysroot/usr/lib/systemd/system
mapfile -t units < <(cd "$unitdir" && ls urs-*.service)
mapfile -t sources < <(cd "$root/deploy/systemd" && ls ./*.service | sed 's|^\./||')
[[ "${units[*]}" == "${sources[*]}" ]] || fail "installed units '${units[*]}', deploy/systemd has '${sources[*]}'"
[[ -x $sysroot/usr/libexec/urslink/urs-entrypoint && -x $sysroot/usr/libexec/urslink/urs-health ]] ||
  fail "urs-entrypoint and urs-health are not installed in libexec/urslink"

# ---- 1. systemd-analyze verify ----------------------------------------------------------------
cp -an /lib/systemd/system/. "$unitdir/"                  # the targets the units name; ours stay
for tool in sh kill sleep; do cp -n "$(type -P $tool)" "$sysroot/usr/bin/"; done  # ExecStartPost, ExecReload
ln -sfn usr/bin "$sysroot/bin"
for unit in "${units[@]}"; do
  instance=$unit
  [[ $unit == *@.service ]] && instance=${unit%@.service}@test.service
  out=$(systemd-analyze verify --root="$sysroot" "$instance" 2>&1)
  rc=$?
  [[ $rc -eq 0 && -z "$out" ]] || fail "systemd-analyze verify $instance: exit $rc: $out"
  echo "systemd_units: $instance verifies"
done

# ---- 2. readiness -----------------------------------------------------------------------------
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
# start NAME UNIT ROLE VAR=VALUE...: starts urs-entrypoint ROLE as UNIT does (its Environment= lines,
# %S and %i resolved here), the VAR=VALUE given after them, with a notify socket of its own; sets
# $started to its PID.
start() {
  local name=$1 unit=$2 role=$3
  shift 3
  local environment=()
  while IFS= read -r line; do
    line=${line//%S/$work/state}
    environment+=("${line//%i/test}")
  done < <(sed -n 's/^Environment=//p' "$unitdir/$unit")
  python3 "$here/notify_listener.py" "$work/$name.sock" "$work/$name.notify" &
  pids+=($!)
  wait_for "the notify socket of $name" test -S "$work/$name.sock"
  env -i PATH="$sysroot/usr/bin:/usr/bin:/bin" HOME="$work" NOTIFY_SOCKET="$work/$name.sock" \
    "${environment[@]}" "$@" "$sysroot/usr/libexec/urslink/urs-entrypoint" "$role" >"$work/$name.log" 2>&1 &
  started=$!
  pids+=($started)
}
ready_from() { grep -qx "$2 READY=1" "$work/$1.notify" 2>/dev/null; }
urs() { "$sysroot/usr/bin/urs" --server "127.0.0.1:$server_port" "$@"; }
mkdir -p "$work/state"

server_port=$(free_port)
start camus urs-camus-server.service camus-server URS_SPACE=unit URS_LISTEN="127.0.0.1:$server_port"
server=$started
wait_for "READY=1 from urs-camus-server's main PID" ready_from camus "$server"
urs ls >"$work/ls.log" 2>&1 || fail "urs-camus-server said READY=1 but does not answer urs ls"
[[ -d $work/state/urslink/camus ]] || fail "urs-camus-server did not keep its data in the unit's state folder"
echo "systemd_units: urs-camus-server READY=1 once it answers"

printf 'agents:\n  - {name: unit-diag, type: diagnostic}\n' >"$work/sam-test.yaml"
start sam urs-sam@.service sam-host URS_SPACE=unit URS_SERVER="127.0.0.1:$server_port" URS_CONFIG="$work/sam-test.yaml"
sam=$started
wait_for "READY=1 from urs-sam's main PID" ready_from sam "$sam"
urs ls unit-diag 2>/dev/null | grep -q '^unit-diag .*available' || fail "urs-sam said READY=1 before its service was listed"
echo "systemd_units: urs-sam READY=1 once its service is registered"
# A SAM whose service is refused (a name reserved for the server) never says READY=1. (A second
# SAM offering the same name would be its second provider, docs/camus.md.)
printf 'agents:\n  - {name: camus.unit-diag, type: diagnostic}\n' >"$work/sam-refused.yaml"
start sam2 urs-sam@.service sam-host URS_SPACE=unit URS_SERVER="127.0.0.1:$server_port" URS_CONFIG="$work/sam-refused.yaml"
sam2=$started
wait_for "the second SAM's registration refused" grep -q "registering service camus.unit-diag failed: BAD_ARGUMENTS" "$work/sam2.log"
! ready_from sam2 "$sam2" || fail "urs-sam said READY=1 although its service was refused"
echo "systemd_units: a SAM whose service is refused does not say READY=1"

if command -v omniNames >/dev/null && command -v nameclt >/dev/null; then
  naming_port=$(free_port)
  start naming urs-naming.service naming URS_NAMING_PORT="$naming_port" \
    URS_NAMING_ENDPOINT="giop:tcp:127.0.0.1:$naming_port"
  health() {
    env -i PATH="$sysroot/usr/bin:/usr/bin:/bin" URS_NAMING_PORT="$naming_port" "$sysroot/usr/libexec/urslink/urs-health" naming
  }
  wait_for "the naming service's urs-health (the unit's ExecStartPost)" health
  [[ -n $(ls "$work/state/urslink/naming"/omninames-*.dat 2>/dev/null) ]] || fail "omniNames keeps no data in the unit's state folder"
  start rtc urs-rtc-manager@.service rtc-manager URS_SPACE=unit URS_NAMING="127.0.0.1:$naming_port" \
    URS_CONFIG="$sysroot/usr/share/urslink/config/rtc-example.yaml" URS_ADVERTISE=127.0.0.1 URS_HOST_CONTEXT=unit
  rtc=$started
  wait_for "READY=1 from urs-rtc-manager's main PID" ready_from rtc "$rtc"
  listing=$("$sysroot/usr/bin/urs" rtc --naming "127.0.0.1:$naming_port" ls 2>&1) || fail "urs rtc ls failed: $listing"
  echo "$listing" >"$work/rtc-ls.log"
  # Bound, and reachable at the port its ORB took (a state is read from each component).
  grep -qx 'unit.host_cxt/' <<<"$listing" && grep -Eq '\.rtc +(Active|Inactive)$' <<<"$listing" || fail "urs-rtc-manager said READY=1 before its components were bound and reachable: $listing"
  echo "systemd_units: urs-naming passes its readiness check, urs-rtc-manager READY=1 once its components are bound"
else
  fail "omniNames or nameclt is missing (Debian: apt-get install omniorb-nameserver omniorb)"
fi
echo "systemd_units: ${#units[@]} units verify; the CAMUS server, a SAM, the naming service and an RT manager are ready when their units say so"
