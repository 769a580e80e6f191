#!/usr/bin/env bash
# e2e (the .deb under systemd): the package as a robot PC meets it. `cpack -G DEB` in the build
# folder; the .deb installed with apt into a bare Debian container (urslink/base:bookworm, made by
# deploy/images/make-base.sh when missing) with systemd and omniNames, then systemd as the
# container's PID 1; then docs/deployment.md's recipe, "Bare metal with systemd":
#   urslink.env, a token readable by the group urslink, sam-diag.yaml, `systemctl enable --now
#   urs-camus-server urs-sam@diag`: both active once ready, the SAM's diag listed and answering
#   `urs call` through the token, the server's data in its StateDirectory, the SAM run as urslink;
#   the RT side: `systemctl enable --now urs-naming urs-rtc-manager@devices`: the components bound;
#   the bridge (the installed example configuration): the RT diagnostic called from CAMUS; the
#   gateway serving its dashboard's API;
#   `systemctl restart urs-camus-server`: the SAM's and the bridge's services back.
# Removes its container and image. Needs docker (and the Debian mirror apt uses, for the packages).
#   tests/e2e/deb_systemd/run.sh [SOURCE_DIR [BUILD_DIR]]
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=${1:-$(cd "$here/../../.." && pwd)}
build=${2:-${URS_BUILD_DIR:-$root/build}}
test_name=e2e_deb_systemd
source "$here/../steps.sh"

command -v docker >/dev/null || die "docker is not installed (Debian: apt-get install docker.io); this test needs it"
docker info >/dev/null 2>&1 || die "the docker daemon does not answer"
name=urs-deb-e2e-$$
image=urslink/deb-e2e:$$
cleanup() {
  if [[ -n "$failed_step" ]] && docker inspect "$name" >/dev/null 2>&1; then
    docker exec "$name" journalctl --no-pager -n 60 2>/dev/null
  fi
  docker rm -f "$name" "$name-prep" >/dev/null 2>&1
  docker rmi -f "$image" >/dev/null 2>&1
}
trap cleanup EXIT
in_box() { docker exec "$name" bash -c "$1"; }

step "the .deb (cpack -G DEB)"
(cd "$build" && timeout 300 cpack -G DEB >cpack.log 2>&1) || fail "cpack failed: $(tail -20 "$build/cpack.log")"
deb=$build/urslink_0.1.0_amd64.deb
[[ -s $deb ]] || fail "no $deb"

step "installed with apt into a bare Debian container, with systemd"
docker image inspect urslink/base:bookworm >/dev/null 2>&1 || "$root/deploy/images/make-base.sh" ||
  fail "no base image urslink/base:bookworm"
docker run -d --name "$name-prep" -v "$build:/deb:ro" urslink/base:bookworm sleep 600 >/dev/null || fail "docker run"
docker exec "$name-prep" bash -c "apt-get update -q >/tmp/apt.log 2>&1 && DEBIAN_FRONTEND=noninteractive timeout 600 \
  apt-get install -y -q systemd systemd-sysv omniorb-nameserver omniorb /deb/$(basename "$deb") >>/tmp/apt.log 2>&1" ||
  fail "apt-get install: $(docker exec "$name-prep" tail -20 /tmp/apt.log)"
docker commit "$name-prep" "$image" >/dev/null && docker rm -f "$name-prep" >/dev/null || fail "docker commit"
docker run -d --name "$name" --tmpfs /run --tmpfs /run/lock -v /sys/fs/cgroup:/sys/fs/cgroup:ro \
  --entrypoint /lib/systemd/systemd "$image" >/dev/null || fail "systemd in the container did not start"
running() { [[ $(docker exec "$name" systemctl is-system-running 2>/dev/null) =~ ^(running|degraded)$ ]]; }
eventually 60 running || fail "systemd is $(docker exec "$name" systemctl is-system-running 2>&1)"
in_box 'getent passwd urslink >/dev/null && [[ $(stat -c %G:%a /etc/urslink) == urslink:750 ]]' ||
  fail "the postinst made no user urslink or /etc/urslink"

step "a CAMUS space: systemctl enable --now urs-camus-server urs-sam@diag"
in_box '
  cp /usr/share/urslink/systemd/urslink.env /etc/urslink/urslink.env
  sed -i "s/^URS_SPACE=myspace$/URS_SPACE=lab/" /etc/urslink/urslink.env
  head -c 32 /dev/urandom | base64 > /etc/urslink/lab.token
  chgrp urslink /etc/urslink/lab.token && chmod 0640 /etc/urslink/lab.token
  echo URS_TOKEN_FILE=/etc/urslink/lab.token >> /etc/urslink/urslink.env
  cp /usr/share/urslink/config/sam-diagnostic.yaml /etc/urslink/sam-diag.yaml
  timeout 120 systemctl enable --now urs-camus-server urs-sam@diag' >/dev/null 2>&1 || fail "systemctl enable --now failed"
# Type=notify: `enable --now` returns once both said READY=1, so the SAM's service is there at once.
out=$(in_box 'systemctl is-active urs-camus-server urs-sam@diag; URS_TOKEN_FILE=/etc/urslink/lab.token urs ls diag') ||
  fail "not active, or diag not listed: $out"
grep -q '^diag .*available' <<<"$out" || fail "diag is not listed as soon as urs-sam@diag is started: $out"
reply=$(in_box 'URS_TOKEN_FILE=/etc/urslink/lab.token urs call diag echo "{\"text\":\"from the deb\"}"') ||
  fail "urs call diag echo: $reply"
[[ $reply == '{"result":"from the deb"}' ]] || fail "urs call diag echo answered $reply"
in_box '[[ $(systemctl show -p User --value urs-sam@diag) == urslink && -n $(ls /var/lib/urslink/camus) ]]' ||
  fail "the SAM does not run as urslink, or the server keeps no data in /var/lib/urslink/camus"
in_box 'urs ls' >/dev/null 2>&1 && fail "the server answered a client without the token"
say "diag answers through the token; the server keeps its data in /var/lib/urslink/camus"

step "an RT space: systemctl enable --now urs-naming urs-rtc-manager@devices"
in_box 'cp /usr/share/urslink/config/rtc-example.yaml /etc/urslink/rtc-manager-devices.yaml
  timeout 120 systemctl enable --now urs-naming urs-rtc-manager@devices' >/dev/null 2>&1 || fail "systemctl enable --now failed"
out=$(in_box 'urs rtc --naming 127.0.0.1:2809 ls') || fail "urs rtc ls: $out"
grep -Eq 'Diagnostic0\.rtc +Inactive$' <<<"$out" || fail "the manager's components are not bound once it is started: $out"

step "the bridge: systemctl enable --now urs-bridge"
in_box 'sed "s|^idl: \[../../idl/|idl: [/usr/share/urslink/idl/|" /usr/share/urslink/config/bridge-example.yaml >/etc/urslink/bridge.yaml
  timeout 120 systemctl enable --now urs-bridge' >/dev/null 2>&1 || fail "systemctl enable --now urs-bridge failed"
bridged() { in_box 'URS_TOKEN_FILE=/etc/urslink/lab.token urs call rt.Diagnostic0 echo "{\"text\":\"RT\"}"' 2>/dev/null | grep -qx '{"result":"RT"}'; }
eventually 30 bridged || fail "the RT diagnostic is not called from CAMUS through urs-bridge"

step "the gateway: systemctl enable --now urs-gateway"
in_box 'timeout 120 systemctl enable --now urs-gateway' >/dev/null 2>&1 || fail "systemctl enable --now urs-gateway failed"
in_box 'python3 -c "import urllib.request; urllib.request.urlopen(\"http://127.0.0.1:8765/api/whoami\", timeout=5)"' ||
  fail "the gateway does not serve /api/whoami once started"

step "systemctl restart urs-camus-server: the SAM and the bridge register again"
in_box 'timeout 60 systemctl restart urs-camus-server' || fail "restart failed"
back() { in_box 'URS_TOKEN_FILE=/etc/urslink/lab.token urs ls' 2>/dev/null | grep -q '^diag ' && bridged; }
eventually 30 back || fail "diag or rt.Diagnostic0 did not come back after the server's restart"
failed=$(in_box 'systemctl --failed --no-legend --plain | grep urs-') && fail "failed units: $failed"
failed_step=""
say "e2e_deb_systemd: the .deb's six units run under systemd as documented"
